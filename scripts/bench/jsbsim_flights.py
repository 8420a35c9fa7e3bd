#!/usr/bin/env python3
"""JSBSim c172x flights with planted model gaps, for testing `aerosid gaps` on data it did not make.

Regenerate (from the repository root, ~1 min of one core):
    target/venv/bin/python scripts/bench/jsbsim_flights.py
Options: --out DIR (default tool/data/jsbsim), --build DIR (default target/jsbsim-build),
         --only NAME[,NAME] (regenerate some flights; truth.json is rewritten from all specs),
         --check (also print the C_Lα sanity check of JSBSim's own logged coefficients).

The package is never edited: c172x is copied into --build and the copy's XML is changed per flight
(a <function> added to an aerodynamic axis, or the thruster moved). Sensor errors are applied to the
logged channels afterwards. See tool/data/jsbsim/README.md.
"""
import argparse
import json
import math
import os
import re
import shutil
import sys

import numpy as np
import jsbsim

FT = 0.3048
LBF = 4.4482216152605
SLUG = 14.593902937206364
SLUGFT2 = 1.3558179483314004
IN = 0.0254
SLUGFT3 = SLUG / FT**3
PKG = os.path.dirname(jsbsim.__file__)

DT = 1.0 / 200.0          # JSBSim integration step
LOG_EVERY = 4             # 200 Hz / 4 = 50 Hz log
DURATION = 90.0
V_TRIM_KT = 95.0
ALT_FT = 4000.0
TURB_TYPE = 3             # FGWinds::ttMilspec (Dryden, MIL-F-8785C)
TURB_SEVERITY = 2         # MIL-F-8785C probability-of-exceedance index 2 (1e-1): light (JSBSim: 3 = 1e-2)
TURB_W20_FPS = 15.0       # windspeed at 20 ft (only used below 1000 ft AGL; we fly at 4000 ft)

# Sensor noise (1 sigma, white, seeded numpy RNG), SI units.
NOISE = {
    "accel": 0.05,        # m/s^2
    "gyro": 0.0015,       # rad/s (0.086 deg/s)
    "euler": 0.0017,      # rad (0.1 deg)
    "airspeed": 0.15,     # m/s
    "vane": 0.0026,       # rad (0.15 deg), alpha and beta vanes
    "surface": 0.0009,    # rad (0.05 deg), potentiometers on the surfaces
    "throttle": 0.002,    # 0..1
    "rho": 0.002,         # kg/m^3
    "thrust": 10.0,       # N
}

ROTATIONAL_GUSTS = False
CLEAN_DROP = ["aero/coefficient/CLadot", "aero/coefficient/Cmadot"]  # removed from every flight

# One flight per entry. xml: list of (axis, function-xml) added; thruster_dz_in: thruster moved
# (structural z, inches, + = up); post: sensor error applied to the logged channels.
SPECS = [
    dict(name="clean_s1", seed=1),
    dict(name="clean_s2", seed=2),
    dict(name="clean_s3", seed=3),
    dict(name="clean_s4", seed=4),
    dict(name="alpha2_CL", seed=11, kind="NonlinearAlpha", location="C_L", size=-12.0, term="α²",
         axis="LIFT", fn="<product><property>aero/qbar-area</property><property>aero/alpha-rad</property>"
                        "<property>aero/alpha-rad</property><value>{k}</value></product>"),
    dict(name="alpha3_CD", seed=12, kind="NonlinearAlpha", location="C_D", size=100.0, term="α³",
         axis="DRAG", fn="<product><property>aero/qbar-area</property><property>aero/alpha-rad</property>"
                        "<property>aero/alpha-rad</property><property>aero/alpha-rad</property><value>{k}</value></product>"),
    dict(name="alphadot_Cm", seed=13, kind="AlphaDot", location="C_m", size=-8.0, term="α̇ c̄/(2V)", terms=["α̇_n"],
         axis="PITCH", fn="<product><property>aero/qbar-area</property><property>metrics/cbarw-ft</property>"
                         "<property>aero/ci2vel</property><property>aero/alphadot-rad_sec</property><value>{k}</value></product>"),
    dict(name="beta2_Cm", seed=14, kind="CrossCoupling", accept_kinds=["CrossCoupling", "NonlinearBeta"],
         location="C_m", size=-2.0, term="β²", terms=["β²", "|β|"],
         axis="PITCH", fn="<product><property>aero/qbar-area</property><property>metrics/cbarw-ft</property>"
                         "<property>aero/beta-rad</property><property>aero/beta-rad</property><value>{k}</value></product>"),
    dict(name="thrust_Cm", seed=15, kind="Thrust", location="C_m", size=-0.15, term="Δz·T/(q̄Sc̄), Δz = -0.15 m (thrust line moved up)",
         terms=["C_T"],
         thruster_dz_in=0.15 / IN),
    dict(name="alphadelta_a_Cn", seed=16, kind="ControlTerm", location="C_n", size=1.5, xml_k=-1.5,
         term="α·δa (project sign: δa + = right aileron TED; adverse yaw growing with lift)", terms=["α·δa"],
         axis="YAW", fn="<product><property>aero/qbar-area</property><property>metrics/bw-ft</property>"
                       "<property>aero/alpha-rad</property><property>fcs/effective-aileron-pos</property><value>{k}</value></product>"),
    dict(name="vane_bias", seed=17, kind="SensorBias", location="Alpha", size=math.radians(2.0), term="α_vane = α + 2°",
         post="alpha_bias"),
    dict(name="vane_scale", seed=18, kind="ScaleFactor", location="Alpha", size=0.10, term="α_vane = 1.10 α",
         post="alpha_scale"),
    dict(name="elevator_delay", seed=19, kind="ControlDelay", location="Elevator", size=0.06,
         term="logged δe(t) = surface δe(t + 0.06 s)", post="elevator_lead"),
]


def build_aircraft(build, spec):
    """Copy c172x to build/aircraft/<name>/<name>.xml with the spec's edits; return the name."""
    name = "c172x_" + spec["name"]
    src = os.path.join(PKG, "aircraft", "c172x")
    dst = os.path.join(build, "aircraft", name)
    if os.path.isdir(dst):
        shutil.rmtree(dst)
    shutil.copytree(src, dst)
    for d in ("engine", "systems"):
        link = os.path.join(build, d)
        if not os.path.exists(link):
            os.symlink(os.path.join(PKG, d), link)
    xml = open(os.path.join(src, "c172x.xml")).read()
    # Clean baseline: no alpha-dot terms (eq. 3 has none; the alphadot flight plants one back).
    for fname in CLEAN_DROP:
        xml, n = re.subn(r'<function name="%s">.*?</function>' % re.escape(fname), "", xml, flags=re.S)
        assert n == 1, fname
    # Symmetric loading: the 80 lb "PesticideBomb" point mass sits 12 ft out on the right wing.
    xml, n = re.subn(r'(<pointmass name="PesticideBomb">\s*<weight unit="LBS">)80.0(</weight>)', r"\g<1>0.0\2", xml)
    assert n == 1
    # Rotational gusts: JSBSim's Milspec model also makes p_g, q_g, r_g, which reach the aerodynamics
    # only through velocities/[pqr]-aero-rad_sec in the damping terms. The baseline aircraft uses the
    # body rates there instead (see README: at severity 2 q_g was 0.018 rad/s RMS, ~6 % of C_m's
    # variance, and correlated with the gust's alpha-dot). --rotational-gusts keeps JSBSim's coupling.
    if not ROTATIONAL_GUSTS:
        xml, n = re.subn(r"velocities/([pqr])-aero-rad_sec", r"velocities/\1-rad_sec", xml)
        assert n == 10, n   # CLq, CYp, CYr, Clp, Clr, Cmq, Cnp, Cnr, wing-tip alpha (p, r)
    # No output files from the model itself.
    xml = re.sub(r'<output name="JSBout172B.csv".*?</output>', "", xml, flags=re.S)
    if "axis" in spec:
        fn = '<function name="aero/coefficient/planted"><description>planted: %s</description>%s</function>' % (
            spec["term"], spec["fn"].format(k=repr(spec.get("xml_k", spec["size"]))))
        pat = r'(<axis name="%s">)' % spec["axis"]
        xml, n = re.subn(pat, r"\1" + fn.replace("\\", "\\\\"), xml)
        assert n == 1
    if "thruster_dz_in" in spec:
        xml, n = re.subn(r"(<thruster file=\"prop_75in2f\">\s*<location unit=\"IN\">\s*<x>-37.7</x>\s*<y>0</y>\s*<z>)26.6(</z>)",
                         r"\g<1>%.4f\2" % (26.6 + spec["thruster_dz_in"]), xml)
        assert n == 1
    os.remove(os.path.join(dst, "c172x.xml"))
    open(os.path.join(dst, name + ".xml"), "w").write(xml)
    return name


def unit(t, t0, w):
    return 1.0 if t0 <= t < t0 + w else 0.0


def s3211(t, t0, dt):
    """3-2-1-1: +1 for 3dt, -1 for 2dt, +1 for dt, -1 for dt."""
    x = t - t0
    if x < 0:
        return 0.0
    for a, b, v in ((0, 3, 1), (3, 5, -1), (5, 6, 1), (6, 7, -1)):
        if a * dt <= x < b * dt:
            return float(v)
    return 0.0


def doublet(t, t0, dt):
    x = t - t0
    return 1.0 if 0 <= x < dt else (-1.0 if dt <= x < 2 * dt else 0.0)


def inputs(t, sign):
    """Pilot inputs on top of the trim: (elevator, aileron, rudder, throttle) in JSBSim's normalised
    command units. sign (+1/-1 per flight) flips the direction of every manoeuvre."""
    de = 0.12 * s3211(t, 5.0, 0.5) + 0.15 * doublet(t, 15.0, 0.7) + 0.12 * s3211(t, 55.0, 0.5) + 0.15 * doublet(t, 85.0, 0.7)
    da = 0.20 * s3211(t, 25.0, 0.5) + 0.20 * s3211(t, 65.0, 0.5)
    dr = 0.30 * doublet(t, 35.0, 1.0) + 0.30 * doublet(t, 75.0, 1.0)
    dth = -0.25 * unit(t, 45.0, 25.0)
    return sign * de, sign * da, sign * dr, dth


PROPS = {
    "t": "simulation/sim-time-sec",
    "fbx": "forces/fbx-total-lbs", "fby": "forces/fby-total-lbs", "fbz": "forces/fbz-total-lbs",
    "mass": "inertia/mass-slugs",
    "p": "velocities/p-rad_sec", "q": "velocities/q-rad_sec", "r": "velocities/r-rad_sec",
    "phi": "attitude/phi-rad", "theta": "attitude/theta-rad", "psi": "attitude/psi-rad",
    "vt": "velocities/vt-fps", "alpha": "aero/alpha-rad", "beta": "aero/beta-rad",
    "alphadot": "aero/alphadot-rad_sec",
    "de": "fcs/elevator-pos-rad", "da_eff": "fcs/effective-aileron-pos", "dr": "fcs/rudder-pos-rad",
    "thr": "fcs/throttle-pos-norm", "rho": "atmosphere/rho-slugs_ft3", "thrust": "propulsion/engine/thrust-lbs",
    "qbar": "aero/qbar-psf", "h": "position/h-sl-ft",
    "lift": "forces/fwz-aero-lbs", "drag": "forces/fwx-aero-lbs", "side": "forces/fwy-aero-lbs",
    "Lm": "moments/l-aero-lbsft", "Mm": "moments/m-aero-lbsft", "Nm": "moments/n-aero-lbsft",
    "pa": "velocities/p-aero-rad_sec", "qa": "velocities/q-aero-rad_sec", "ra": "velocities/r-aero-rad_sec",
    "cgx": "inertia/cg-x-in", "cgy": "inertia/cg-y-in", "cgz": "inertia/cg-z-in",
    "turb_n": "atmosphere/turb-north-fps", "turb_e": "atmosphere/turb-east-fps", "turb_d": "atmosphere/turb-down-fps",
    "pturb": "atmosphere/p-turb-rad_sec", "qturb": "atmosphere/q-turb-rad_sec", "rturb": "atmosphere/r-turb-rad_sec",
    "u": "velocities/u-fps", "w": "velocities/w-fps",
    "vn": "velocities/v-north-fps", "ve": "velocities/v-east-fps", "vd": "velocities/v-down-fps",
    "wind_n": "atmosphere/total-wind-north-fps", "wind_e": "atmosphere/total-wind-east-fps",
    "wind_d": "atmosphere/total-wind-down-fps",
}


def axis_functions(build, acname):
    xml = open(os.path.join(build, "aircraft", acname, acname + ".xml")).read()
    out = {}
    for ax, body in re.findall(r'<axis name="(\w+)">(.*?)</axis>', xml, flags=re.S):
        names = re.findall(r'<function name="(aero/coefficient/[^"]+)">', body)
        out[ax] = names
    return out


def simulate(build, acname, seed, sign, duration=DURATION, inputs_fn=inputs):
    """Trim, then fly `duration` s of `inputs_fn(t, sign)` under the stabiliser; the 200 Hz record."""
    fdm = jsbsim.FGFDMExec(build)
    fdm.set_debug_level(0)
    fdm.disable_output()
    if not fdm.load_model(acname):
        raise SystemExit("load_model failed: " + acname)
    fdm.set_dt(DT)
    fdm["ic/h-sl-ft"] = ALT_FT
    fdm["ic/vt-kts"] = V_TRIM_KT
    fdm["ic/gamma-deg"] = 0.0
    fdm["ic/psi-true-deg"] = 200.0
    fdm["ic/lat-geod-deg"] = 28.0
    fdm["ic/long-gc-deg"] = -90.0
    fdm["simulation/randomseed"] = seed
    fdm["atmosphere/randomseed"] = seed
    fdm.run_ic()
    fdm["propulsion/set-running"] = -1
    fdm["fcs/mixture-cmd-norm"] = 0.87
    fdm["fcs/throttle-cmd-norm"] = 0.8
    fdm.run()
    fdm["simulation/do_simple_trim"] = 1
    trim = {k: fdm[k] for k in ("fcs/elevator-cmd-norm", "fcs/aileron-cmd-norm", "fcs/rudder-cmd-norm",
                                "fcs/throttle-cmd-norm", "fcs/pitch-trim-cmd-norm")}
    # Trim found: fly steady for a few seconds before turning on turbulence and logging (t = 0).
    theta0 = fdm["attitude/theta-rad"]
    psi0 = fdm["attitude/psi-rad"]
    fdm["atmosphere/turb-type"] = TURB_TYPE
    fdm["atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps"] = TURB_W20_FPS
    fdm["atmosphere/turbulence/milspec/severity"] = TURB_SEVERITY
    n = int(round((duration + 0.2) / DT))
    axes = axis_functions(build, acname)
    rec = {k: np.empty(n) for k in list(PROPS) + ["axis_" + a for a in axes]}
    t_start = fdm["simulation/sim-time-sec"]
    for i in range(n):
        t = i * DT
        de, da, dr, dth = inputs_fn(t, sign)
        # Light stabiliser (wings leveller, pitch-attitude hold, heading via rudder), as a pilot or
        # an autopilot flying the manoeuvre would; it acts on the true attitude.
        phi, theta = fdm["attitude/phi-rad"], fdm["attitude/theta-rad"]
        dpsi = (fdm["attitude/psi-rad"] - psi0 + math.pi) % (2 * math.pi) - math.pi
        fdm["fcs/elevator-cmd-norm"] = trim["fcs/elevator-cmd-norm"] + de + 0.6 * (theta - theta0) + 0.15 * fdm["velocities/q-rad_sec"]
        fdm["fcs/aileron-cmd-norm"] = trim["fcs/aileron-cmd-norm"] + da - 0.8 * phi - 0.3 * dpsi - 0.2 * fdm["velocities/p-rad_sec"]
        fdm["fcs/rudder-cmd-norm"] = trim["fcs/rudder-cmd-norm"] + dr
        fdm["fcs/throttle-cmd-norm"] = trim["fcs/throttle-cmd-norm"] + dth
        fdm.run()
        for k, p in PROPS.items():
            rec[k][i] = fdm[p]
        for ax, names in axes.items():
            rec["axis_" + ax][i] = sum(fdm[nm] for nm in names)
    rec["t"] -= t_start + DT
    extra = dict(trim=trim, J=np.array(fdm.get_mass_balance().get_J()), mass=fdm["inertia/mass-slugs"],
                 cg=(fdm["inertia/cg-x-in"], fdm["inertia/cg-y-in"], fdm["inertia/cg-z-in"]))
    return fdm, rec, extra


S_M2 = 174.0 * FT**2
B_M = 36.0 * FT
C_M = 4.9 * FT
AERORP_IN = (43.2, 0.0, 59.4)
THRUSTER_IN = (-37.7, 0.0, 26.6)
LEAD_STEPS = int(round(0.06 / DT))   # 60 ms at 200 Hz


def struct_to_body_m(p_in, cg_in):
    """JSBSim structural frame (x aft, y right, z up, inches) to body FRD relative to the CG (m)."""
    return (-(p_in[0] - cg_in[0]) * IN, (p_in[1] - cg_in[1]) * IN, -(p_in[2] - cg_in[2]) * IN)


def truth_signals(rec):
    """SI truth at the 200 Hz rate (project conventions)."""
    V = rec["vt"] * FT
    qbar = rec["qbar"] * LBF / FT**2
    d = dict(
        V=V, qbar=qbar, alpha=rec["alpha"], beta=rec["beta"],
        de=rec["de"], da=-rec["da_eff"], dr=rec["dr"],
        qn=rec["q"] * C_M / (2 * V), pn=rec["p"] * B_M / (2 * V), rn=rec["r"] * B_M / (2 * V),
        adn=rec["alphadot"] * C_M / (2 * V), thrust=rec["thrust"] * LBF,
    )
    qS = qbar * S_M2
    # Pure aerodynamic coefficients: the sums of the XML axis functions (moments about AERORP).
    d["C_L"] = rec["axis_LIFT"] * LBF / qS
    d["C_D"] = rec["axis_DRAG"] * LBF / qS
    d["C_Y"] = rec["axis_SIDE"] * LBF / qS
    d["C_l"] = rec["axis_ROLL"] * LBF * FT / (qS * B_M)
    d["C_m"] = rec["axis_PITCH"] * LBF * FT / (qS * C_M)
    d["C_n"] = rec["axis_YAW"] * LBF * FT / (qS * B_M)
    return d


BASE = {
    "C_L": ["1", "alpha", "qn", "de"], "C_m": ["1", "alpha", "qn", "de"],
    "C_D": ["1", "alpha", "alpha2", "qn", "de"],
    "C_Y": ["1", "beta", "pn", "rn", "da", "dr"], "C_l": ["1", "beta", "pn", "rn", "da", "dr"],
    "C_n": ["1", "beta", "pn", "rn", "da", "dr"],
}


def design(d, names):
    cols = []
    for n in names:
        cols.append(np.ones_like(d["alpha"]) if n == "1" else d["alpha"] ** 2 if n == "alpha2" else d[n])
    return np.column_stack(cols)


def planted_contribution(spec, d):
    k = spec.get("size")
    kind = spec.get("kind")
    if spec.get("axis") is None and "thruster_dz_in" not in spec:
        return None
    a = d["alpha"]
    if spec["name"] == "alpha2_CL":
        return k * a**2
    if spec["name"] == "alpha3_CD":
        return k * a**3
    if spec["name"] == "alphadot_Cm":
        return k * d["adn"]
    if spec["name"] == "beta2_Cm":
        return k * d["beta"] ** 2
    if spec["name"] == "thrust_Cm":
        return k * d["thrust"] / (d["qbar"] * S_M2 * C_M)
    if spec["name"] == "alphadelta_a_Cn":
        return k * a * d["da"]
    raise ValueError(kind)


def rms(x):
    return float(np.sqrt(np.mean((x - x.mean()) ** 2)))


def sanity_fit(d, coef):
    X = design(d, BASE[coef])
    th, *_ = np.linalg.lstsq(X, d[coef], rcond=None)
    r = d[coef] - X @ th
    return dict(zip(BASE[coef], th)), rms(r), rms(d[coef])


def write_csv(path, cols, fmts):
    names = list(cols)
    n = len(cols[names[0]])
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        fmt = ",".join(fmts[c] for c in names) + "\n"
        data = np.column_stack([cols[c] for c in names])
        for row in data:
            f.write(fmt % tuple(row))
    return n


def measured(spec, rec, rng):
    """Decimate to 50 Hz, add sensor noise and the spec's sensor error; return the CSV columns."""
    n_out = int(round(DURATION / DT))
    idx = np.arange(0, n_out, LOG_EVERY)
    m_kg = rec["mass"] * SLUG
    sf = {ax: rec["fb" + ax] * LBF / m_kg for ax in "xyz"}   # specific force at the CG, body FRD
    de_true = rec["de"]
    de_log = de_true.copy()
    if spec.get("post") == "elevator_lead":
        de_log = np.concatenate([de_true[LEAD_STEPS:], np.repeat(de_true[-1], LEAD_STEPS)])
    alpha_true = rec["alpha"]
    alpha_vane = alpha_true.copy()
    if spec.get("post") == "alpha_bias":
        alpha_vane = alpha_true + spec["size"]
    if spec.get("post") == "alpha_scale":
        alpha_vane = (1.0 + spec["size"]) * alpha_true
    N = len(idx)
    g = lambda s: rng.normal(0.0, s, N)
    psi = np.unwrap(rec["psi"][idx])
    c = {}
    c["t_s"] = rec["t"][idx]
    c["accel_mps2_x"] = sf["x"][idx] + g(NOISE["accel"])
    c["accel_mps2_y"] = sf["y"][idx] + g(NOISE["accel"])
    c["accel_mps2_z"] = sf["z"][idx] + g(NOISE["accel"])
    c["gyro_rad_s_x"] = rec["p"][idx] + g(NOISE["gyro"])
    c["gyro_rad_s_y"] = rec["q"][idx] + g(NOISE["gyro"])
    c["gyro_rad_s_z"] = rec["r"][idx] + g(NOISE["gyro"])
    c["airspeed_mps"] = rec["vt"][idx] * FT + g(NOISE["airspeed"])
    c["alpha_rad"] = alpha_vane[idx] + g(NOISE["vane"])
    c["beta_rad"] = rec["beta"][idx] + g(NOISE["vane"])
    c["euler_rad_x"] = rec["phi"][idx] + g(NOISE["euler"])
    c["euler_rad_y"] = rec["theta"][idx] + g(NOISE["euler"])
    c["euler_rad_z"] = psi + g(NOISE["euler"])
    c["elevator_rad"] = de_log[idx] + g(NOISE["surface"])
    c["aileron_rad"] = -rec["da_eff"][idx] + g(NOISE["surface"])   # project sign: right aileron TED +
    c["rudder_rad"] = rec["dr"][idx] + g(NOISE["surface"])
    c["throttle"] = rec["thr"][idx] + g(NOISE["throttle"])
    c["air_density_kgpm3"] = rec["rho"][idx] * SLUGFT3 + g(NOISE["rho"])
    c["thrust_n"] = rec["thrust"][idx] * LBF + g(NOISE["thrust"])
    if spec.get("post") in ("alpha_bias", "alpha_scale"):
        c["truth_alpha_rad"] = alpha_true[idx]
    if spec.get("post") == "elevator_lead":
        c["truth_elevator_rad"] = de_true[idx]
    return c


FMTS = {"t_s": "%.2f", "accel_mps2_x": "%.3f", "accel_mps2_y": "%.3f", "accel_mps2_z": "%.3f",
        "gyro_rad_s_x": "%.5f", "gyro_rad_s_y": "%.5f", "gyro_rad_s_z": "%.5f", "airspeed_mps": "%.2f",
        "alpha_rad": "%.5f", "beta_rad": "%.5f", "euler_rad_x": "%.5f", "euler_rad_y": "%.5f",
        "euler_rad_z": "%.5f", "elevator_rad": "%.5f", "aileron_rad": "%.5f", "rudder_rad": "%.5f",
        "throttle": "%.4f", "air_density_kgpm3": "%.4f", "thrust_n": "%.1f",
        "truth_alpha_rad": "%.5f", "truth_elevator_rad": "%.5f"}

# Known effects of c172x itself (the clean baseline aircraft built above) that a correct analysis
# with the linear eq. 3 baseline may legitimately name. Read from c172x.xml (JSBSim 1.3.3).
TABLE_EFFECTS = [
    {"location": "C_L", "term": "α² / α³ (CLwbh table: slope 5.2 below α = 0, 5.3 on 0…0.09 rad, 10 on 0.09…0.10, 4.5 above; "
                                "CLalpha = α·table(α, β) falling from 4.73 at α = −7° to 4.27 at 10°)", "kind": "NonlinearAlpha"},
    {"location": "C_L", "term": "α·β² (CLalpha table falls with |β|: −1.1 % at |β| = 5°)", "kind": "CrossCoupling",
     "terms": ["β²", "|β|"]},
    {"location": "C_D", "term": "α³ (CDwbh table in α, not a parabola)", "kind": "NonlinearAlpha"},
    {"location": "C_D", "term": "|δe| (CDDe = 0.06·|δe|)", "kind": "ControlTerm", "terms": ["|δe|", "δe²"]},
    {"location": "C_D", "term": "|β| (CDbeta = 0.17·|β|)", "kind": "NonlinearBeta", "terms": ["|β|", "β²"]},
    {"location": "C_Y", "term": "β·|β| (the drag acts along the wind axis: the body side force carries −C_D·sin β, and CDbeta = "
                                "0.17·|β| makes that −0.17·β·|β|, odd in β; over these flights' β its projection on β³ beside β is "
                                "−1.5…−1.8)", "kind": "NonlinearBeta", "terms": ["β³"]},
    {"location": "C_l", "term": "α·r̂ (Clr table: 0.08 at α = 0, 0.19 at α = 0.094 rad)", "kind": "CrossCoupling",
     "terms": ["α·r_n"]},
    {"location": "C_l", "term": "C_T (propeller torque reacts on the airframe as a rolling moment; sense −1)", "kind": "Thrust"},
    {"location": "C_n", "term": "C_T·α, C_T·β (propeller P-factor, p_factor = 10: the thrust point moves sideways with the flow angle)", "kind": "Thrust",
     "terms": ["C_T·α", "C_T·β"]},
    {"location": "C_n", "term": "q̂ (propeller gyroscopic moment, I_prop = 1.67 slug·ft², with the pitch rate)", "kind": "CrossCoupling",
     "terms": ["q_n"]},
    {"location": "C_m", "term": "r̂ (propeller gyroscopic moment with the yaw rate)", "kind": "CrossCoupling",
     "terms": ["r_n"]},
    {"location": "C_m", "term": "C_T (thrust changes with the inflow: the stated thrust point is exact, but the P-factor moves the thrust point vertically with β)", "kind": "Thrust"},
]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="tool/data/jsbsim")
    ap.add_argument("--build", default="target/jsbsim-build")
    ap.add_argument("--only", default="")
    ap.add_argument("--rotational-gusts", action="store_true")
    a = ap.parse_args()
    global ROTATIONAL_GUSTS
    ROTATIONAL_GUSTS = a.rotational_gusts
    os.makedirs(a.build, exist_ok=True)
    os.makedirs(a.out, exist_ok=True)
    build = os.path.abspath(a.build)
    only = set(x for x in a.only.split(",") if x)
    truth = {"generator": "scripts/bench/jsbsim_flights.py", "jsbsim": jsbsim.__version__, "aircraft": "c172x",
             "conventions": "project: body FRD; δe + trailing edge down (= JSBSim fcs/elevator-pos-rad); "
                            "δa + right aileron trailing edge down (= −fcs/effective-aileron-pos); "
                            "δr + trailing edge left (= fcs/rudder-pos-rad). Sizes in these conventions, "
                            "coefficients about the moment reference point (= JSBSim AERORP).",
             "flights": {}}
    sanity = {}
    for i, spec in enumerate(SPECS):
        ac = build_aircraft(build, spec)
        sign = 1 if spec["seed"] % 2 else -1
        fdm, rec, extra = simulate(build, ac, spec["seed"], sign)
        d = truth_signals(rec)
        entry = None
        if "kind" in spec:
            entry = {"kind": spec["kind"], "location": spec["location"], "size": spec["size"], "term": spec["term"]}
            if "terms" in spec:
                entry["terms"] = spec["terms"]
            if "accept_kinds" in spec:
                entry["accept_kinds"] = spec["accept_kinds"]
        contrib = planted_contribution(spec, d)
        msg = ""
        if contrib is not None:
            coef = spec["location"]
            X = design(d, BASE[coef])
            th, *_ = np.linalg.lstsq(X, contrib, rcond=None)
            unexpl = contrib - X @ th
            entry["rms_contribution"] = round(rms(contrib), 6)
            entry["rms_beyond_baseline"] = round(rms(unexpl), 6)
            entry["rms_coefficient"] = round(rms(d[coef]), 6)
            msg = "planted %s in %s: RMS %.2e (beyond eq.3 baseline %.2e) vs %s RMS %.2e" % (
                spec["term"], coef, rms(contrib), rms(unexpl), coef, rms(d[coef]))
        elif entry is not None:
            msg = "sensor error %s on %s" % (spec["term"], spec["location"])
        truth["flights"][spec["name"] + ".csv"] = {"planted": entry, "seed": spec["seed"], "manoeuvre_sign": sign,
                                                    "table_effects": TABLE_EFFECTS}
        sanity[spec["name"]] = {c: sanity_fit(d, c) for c in BASE}
        print("%-16s alpha %.3f..%.3f rad, V %.1f..%.1f m/s, beta ±%.3f; %s" % (
            spec["name"], d["alpha"].min(), d["alpha"].max(), d["V"].min(), d["V"].max(), np.abs(d["beta"]).max(), msg))
        if only and spec["name"] not in only:
            continue
        rng = np.random.default_rng(1000 + spec["seed"])
        cols = measured(spec, rec, rng)
        write_csv(os.path.join(a.out, spec["name"] + ".csv"), cols, FMTS)
        if spec["name"] == "clean_s1":
            cg = extra["cg"]
            write_aircraft(os.path.join(a.out, "c172x.aircraft"), extra, rec)
            turb = np.sqrt(rec["turb_n"] ** 2 + rec["turb_e"] ** 2 + rec["turb_d"] ** 2) * FT
            print("turbulence: RMS north %.2f east %.2f down %.2f m/s, |gust| max %.2f m/s; rotational p,q,r RMS %.4f %.4f %.4f rad/s" % (
                rms(rec["turb_n"] * FT), rms(rec["turb_e"] * FT), rms(rec["turb_d"] * FT), turb.max(),
                rms(rec["pturb"]), rms(rec["qturb"]), rms(rec["rturb"])))
            print("alpha air-relative minus inertial: RMS %.4f rad" % rms(rec["alpha"] - np.arctan2(rec["w"], rec["u"])))
    with open(os.path.join(a.out, "truth.json"), "w") as f:
        json.dump(truth, f, indent=1, ensure_ascii=False)
    print("\nSanity check: eq. 3 least squares on JSBSim's own coefficients (truth signals, whole flight)")
    for name, fits in sanity.items():
        s = []
        for c in ("C_L", "C_m", "C_D", "C_l", "C_n"):
            th, r, z = fits[c]
            key = {"C_L": "alpha", "C_m": "alpha", "C_D": "alpha", "C_l": "da", "C_n": "dr"}[c]
            s.append("%s_%s %.3f (R² %.4f)" % (c, key, th[key], 1 - (r / z) ** 2))
        print("  %-16s %s" % (name, "; ".join(s)))
    json.dump({k: {c: {"params": v[0], "rms_resid": v[1], "rms": v[2]} for c, v in f.items()} for k, f in sanity.items()},
              open(os.path.join(build, "sanity.json"), "w"), indent=1)


def write_aircraft(path, extra, rec):
    J = extra["J"]
    cg = extra["cg"]
    mref = struct_to_body_m(AERORP_IN, cg)
    thr = struct_to_body_m(THRUSTER_IN, cg)
    txt = f"""# JSBSim c172x (JSBSim {jsbsim.__version__}, aircraft/c172x/c172x.xml as shipped in the Python package),
# as flown by scripts/bench/jsbsim_flights.py: CLadot and Cmadot removed, the 80 lb "PesticideBomb"
# point mass set to 0 lb, full fuel (2 × 130 lb). Mass, CG and inertia are JSBSim's own values at
# t = 0 of clean_s1 (properties inertia/*, FGMassBalance J); over 90 s the fuel burn changes them by
# < 0.1 %. Format: docs/measured-data.md. US units converted on reading.
name = JSBSim c172x (Cessna 172P model, planted-effect benchmark flights)

# inertia/mass-slugs: 1454 lb empty + 686 lb point masses + 260 lb fuel = 2400 lb.
mass_slug = {extra['mass']:.6f}
# FGMassBalance J (slug·ft², body axes, point masses and tanks included; XML <mass_balance> ixx 948,
# iyy 1346, izz 1967 are the empty aircraft's). J(1,3) = {J[0, 2]:.4f} is the tensor element −∫xz dm,
# so the positive-convention Jxz = {-J[0, 2]:.4f}. The small Ixy = {-J[0, 1]:.4f}, Iyz = {-J[1, 2]:.4f}
# (asymmetric pilot/passenger weights) are not in the project's model.
jx_slugft2 = {J[0, 0]:.4f}
jy_slugft2 = {J[1, 1]:.4f}
jz_slugft2 = {J[2, 2]:.4f}
jxz_slugft2 = {-J[0, 2]:.4f}
# <metrics>: wingarea 174.0 ft², wingspan 36.0 ft, chord 4.9 ft (JSBSim metrics/Sw-sqft, bw-ft, cbarw-ft).
wing_area_ft2 = 174.0
span_ft = 36.0
chord_ft = 4.9

# The vanes, the pitot and the accelerometer are taken at the CG: the flights log JSBSim's
# aero/alpha-rad, aero/beta-rad, velocities/vt-fps (air-relative, at the CG) and the specific force
# forces/fb*-total-lbs / mass (at the CG), so the defaults (0) are exact.

# Moment reference: JSBSim applies the aerodynamic forces at AERORP (<metrics> x 43.2, y 0, z 59.4 in,
# structural) and the XML's PITCH/ROLL/YAW axes are the moments about it. CG at t = 0 (inertia/cg-*-in):
# ({cg[0]:.4f}, {cg[1]:.4f}, {cg[2]:.4f}) in. AERORP − CG in body FRD (x = −Δx_s, z = −Δz_s):
moment_reference_x_m = {mref[0]:.5f}
moment_reference_y_m = {mref[1]:.5f}
moment_reference_z_m = {mref[2]:.5f}

# Thrust: propulsion/engine/thrust-lbs logged as thrust_n. The thruster (prop_75in2f) at
# <thruster><location> x −37.7, y 0, z 26.6 in, orient 0 (along body x), relative to the CG in FRD.
# (The thrust_Cm flight moves the thruster 0.15 m up without telling this file: that is its planted gap.)
thrust = measured
thrust_x_m = {thr[0]:.5f}
thrust_y_m = {thr[1]:.5f}
thrust_z_m = {thr[2]:.5f}
thrust_pitch_rad = 0
"""
    open(path, "w").write(txt)


if __name__ == "__main__":
    main()
