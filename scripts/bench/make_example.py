#!/usr/bin/env python3
"""Test helper: build an example benchmark manifest + regression tables from the vendored JSBSim
flights, in the layout the Rust side writes (scripts/bench/README.md), so that peers.py and score.py
can be run end to end without the Rust side.

    target/venv/bin/python scripts/bench/make_example.py [--out /tmp/aerosid-bench-example] [--toy]

The coefficients are synthesised here crudely (Savitzky-Golay ±0.1 s smoothing and derivative,
eq. 1-2 with the aircraft file's mass, inertia, thrust point and moment reference; no flight-path
reconstruction, no sensor-position corrections) - a test fixture, not the project's synthesis.
The "aerosid" entry of each flight is a placeholder (nothing named, 0 s) unless --fake-aerosid,
which names the planted effect (to exercise score.py). --toy adds a 2-flight synthetic suite
"sim" with a known linear truth (one clean, one with α² in C_L).
"""
import argparse
import json
import os

import numpy as np
from scipy.signal import savgol_filter

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "tool", "data", "jsbsim")
FT, SLUG, SLUGFT2 = 0.3048, 14.593902937206364, 1.3558179483314004

BASE = {"C_L": ["1", "α", "q̂", "δe"], "C_m": ["1", "α", "q̂", "δe"], "C_D": ["1", "α", "α²", "q̂", "δe"],
        "C_Y": ["1", "β", "p̂", "r̂", "δa", "δr"], "C_l": ["1", "β", "p̂", "r̂", "δa", "δr"],
        "C_n": ["1", "β", "p̂", "r̂", "δa", "δr"]}
LON_CANDS = {"α²": "NonlinearAlpha", "α³": "NonlinearAlpha", "|δe|": "ControlTerm", "δe²": "ControlTerm",
             "α·δe": "ControlTerm", "α·q̂": "RateNonlinearity", "α̇": "AlphaDot", "β²": "CrossCoupling",
             "|β|": "CrossCoupling", "ΔV/V": "SpeedDependence", "C_T": "Thrust", "C_T·δe": "Thrust",
             "δė": "ControlDelay"}
LAT_CANDS = {"β³": "NonlinearBeta", "α·β": "CrossCoupling", "α·p̂": "CrossCoupling", "α·r̂": "CrossCoupling",
             "α·δa": "ControlTerm", "β̇": "AlphaDot", "ΔV/V": "SpeedDependence", "C_T": "Thrust"}


def read_aircraft(path):
    kv = {}
    for line in open(path):
        line = line.split("#")[0].strip()
        if "=" in line:
            k, v = [s.strip() for s in line.split("=", 1)]
            kv[k] = v
    f = lambda k, s: float(kv[k]) * s
    return dict(m=f("mass_slug", SLUG), Jx=f("jx_slugft2", SLUGFT2), Jy=f("jy_slugft2", SLUGFT2),
                Jz=f("jz_slugft2", SLUGFT2), Jxz=f("jxz_slugft2", SLUGFT2), S=f("wing_area_ft2", FT**2),
                b=f("span_ft", FT), c=f("chord_ft", FT),
                rP=np.array([float(kv["moment_reference_%s_m" % a]) for a in "xyz"]),
                rT=np.array([float(kv["thrust_%s_m" % a]) for a in "xyz"]))


def columns_from_flight(csv, ac):
    d = np.genfromtxt(csv, delimiter=",", names=True)
    dt = np.median(np.diff(d["t_s"]))
    sm = lambda x: savgol_filter(x, 11, 2)
    der = lambda x: savgol_filter(x, 11, 2, deriv=1, delta=dt)
    V, a, b = sm(d["airspeed_mps"]), sm(d["alpha_rad"]), sm(d["beta_rad"])
    rho = sm(d["air_density_kgpm3"])
    qbar = 0.5 * rho * V**2
    p, q, r = sm(d["gyro_rad_s_x"]), sm(d["gyro_rad_s_y"]), sm(d["gyro_rad_s_z"])
    pd, qd, rd = der(d["gyro_rad_s_x"]), der(d["gyro_rad_s_y"]), der(d["gyro_rad_s_z"])
    ax, ay, az = sm(d["accel_mps2_x"]), sm(d["accel_mps2_y"]), sm(d["accel_mps2_z"])
    T = sm(d["thrust_n"])
    de, da, dr = sm(d["elevator_rad"]), sm(d["aileron_rad"]), sm(d["rudder_rad"])
    m, S, bs, c = ac["m"], ac["S"], ac["b"], ac["c"]
    qS = qbar * S
    FA = np.column_stack([m * ax - T, m * ay, m * az])          # aerodynamic force, body
    CX, CY, CZ = FA[:, 0] / qS, FA[:, 1] / qS, FA[:, 2] / qS
    CL = -CZ * np.cos(a) + CX * np.sin(a)
    CD = -CX * np.cos(a) - CZ * np.sin(a)
    Jx, Jy, Jz, Jxz = ac["Jx"], ac["Jy"], ac["Jz"], ac["Jxz"]
    L = Jx * pd - Jxz * rd + (Jz - Jy) * q * r - Jxz * p * q
    M = Jy * qd + (Jx - Jz) * p * r + Jxz * (p**2 - r**2)
    N = Jz * rd - Jxz * pd + (Jy - Jx) * p * q + Jxz * q * r
    Mcg = np.column_stack([L, M, N]) - np.cross(ac["rT"], np.column_stack([T, 0 * T, 0 * T]))
    MP = Mcg - np.cross(ac["rP"], FA)
    z = {"C_L": CL, "C_D": CD, "C_Y": CY, "C_l": MP[:, 0] / (qS * bs), "C_m": MP[:, 1] / (qS * c),
         "C_n": MP[:, 2] / (qS * bs)}
    pn, qn, rn = p * bs / (2 * V), q * c / (2 * V), r * bs / (2 * V)
    CT = T / qS
    x = {"1": np.ones_like(a), "α": a, "β": b, "p̂": pn, "q̂": qn, "r̂": rn, "δe": de, "δa": da, "δr": dr,
         "α²": a**2, "α³": a**3, "|δe|": np.abs(de), "δe²": de**2, "α·δe": a * de, "α·q̂": a * qn,
         "α̇": der(d["alpha_rad"]) * c / (2 * V), "β²": b**2, "|β|": np.abs(b), "ΔV/V": (V - V.mean()) / V.mean(),
         "C_T": CT, "C_T·δe": CT * de, "δė": der(d["elevator_rad"]) * c / (2 * V), "β³": b**3, "α·β": a * b,
         "α·p̂": a * pn, "α·r̂": a * rn, "α·δa": a * da, "β̇": der(d["beta_rad"]) * bs / (2 * V)}
    return d["t_s"], z, x


def coef_spec():
    out = {}
    for c, base in BASE.items():
        cands = LON_CANDS if c in ("C_L", "C_D", "C_m") else LAT_CANDS
        out[c] = {"baseline": base, "candidates": {t: k for t, k in cands.items() if t not in base}}
    return out


def write_table(path, t, z, x):
    names = ["t_s"] + ["z:" + k for k in z] + ["x:" + k for k in x]
    data = np.column_stack([t] + list(z.values()) + list(x.values()))
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        np.savetxt(f, data, delimiter=",", fmt="%.7g")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="/tmp/aerosid-bench-example")
    ap.add_argument("--toy", action="store_true")
    ap.add_argument("--fake-aerosid", action="store_true")
    a = ap.parse_args()
    os.makedirs(os.path.join(a.out, "tables"), exist_ok=True)
    truth = json.load(open(os.path.join(DATA, "truth.json")))
    ac = read_aircraft(os.path.join(DATA, "c172x.aircraft"))
    manifest = []
    for name, tr in truth["flights"].items():
        t, z, x = columns_from_flight(os.path.join(DATA, name), ac)
        tab = "tables/jsbsim_%s.csv" % name[:-4]
        write_table(os.path.join(a.out, tab), t, z, x)
        pl = tr["planted"]
        planted = [] if pl is None else [{k: pl[k] for k in ("kind", "location", "accept_kinds") if k in pl}]
        named = [{"kind": p["kind"], "location": p["location"], "what": "fake"} for p in planted] if a.fake_aerosid else []
        manifest.append({"id": "jsbsim/" + name[:-4], "suite": "jsbsim", "table": tab, "split": int(0.6 * len(t)),
                         "planted": planted, "table_effects": tr["table_effects"], "coefficients": coef_spec(),
                         "aerosid": {"named": named, "seconds": 0.0}})
    if a.toy:
        rng = np.random.default_rng(5)
        for k, planted in enumerate([[], [{"kind": "NonlinearAlpha", "location": "C_L"}]]):
            n = 3000
            t = np.arange(n) * 0.02
            al = 0.05 + 0.03 * np.sin(0.7 * t) + 0.01 * rng.standard_normal(n)
            qn = 0.01 * rng.standard_normal(n)
            de = 0.02 * np.sign(np.sin(0.9 * t))
            x = {"1": np.ones(n), "α": al, "q̂": qn, "δe": de, "α²": al**2, "α̇": np.gradient(al, t) * 0.01}
            zL = 0.3 + 5.0 * al + 4.0 * qn + 0.4 * de + (-8.0 * al**2 if planted else 0) + 0.003 * rng.standard_normal(n)
            tab = "tables/toy_%d.csv" % k
            write_table(os.path.join(a.out, tab), t, {"C_L": zL}, x)
            manifest.append({"id": "sim/toy_%d" % k, "suite": "sim", "table": tab, "split": 1800, "planted": planted,
                             "coefficients": {"C_L": {"baseline": ["1", "α", "q̂", "δe"],
                                                      "candidates": {"α²": "NonlinearAlpha", "α̇": "AlphaDot"}}},
                             "aerosid": {"named": [{"kind": p["kind"], "location": p["location"], "what": "fake"} for p in planted],
                                         "seconds": 0.0}})
    json.dump(manifest, open(os.path.join(a.out, "manifest.json"), "w"), indent=1, ensure_ascii=False)
    print("wrote %s (%d flights)" % (os.path.join(a.out, "manifest.json"), len(manifest)))


if __name__ == "__main__":
    main()
