#!/usr/bin/env python3
"""JSBSim c172x flight-test cards of short manoeuvres, logged as a small UAV's autopilot logs them.

The JSBSim side (aircraft copies, planted effects, trim, stabiliser, turbulence) is
scripts/bench/jsbsim_flights.py's; this script flies six short records per card instead of one long
flight, and logs them the way `aerosid card` logs the project's simulator (sim/src/uav_log.rs,
docs/test-card.md): every channel at its own rate with its own lag and timestamp jitter, held onto
a 50 Hz grid (staircases); no vanes: α and β estimated from the inertial velocity minus a lagged
wind estimate, as ArduPilot's AHRS computes its AOA/SSA.

Regenerate (from the repository root, ~30 s of one core):
    python3 -m venv target/venv && target/venv/bin/pip install jsbsim==1.3.3 numpy
    target/venv/bin/python scripts/bench/jsbsim_card.py
Options: --out DIR (default tool/data/jsbsim_card), --build DIR (default target/jsbsim-build).
"""
import argparse
import copy
import json
import math
import os
import shutil
import sys

import numpy as np
import jsbsim

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import jsbsim_flights as jf  # noqa: E402

LEAD_S = 1.5   # steady lead-in from trim before each manoeuvre

# (record, surface, shape, amplitude in normalised FCS command, base period s, record length s).
# Periods around c172x's modes at 95 kt (short period ≈ 1.3 s, Dutch roll ≈ 3 s); every record
# 5–7 s. Flown with the light stabiliser on (an assisted mode, as the project's card:
# docs/test-card.md), amplitudes sized so that α moves by 2–5° on the elevator records and the bank
# by 15–30° on the aileron records against it (the `excursions` in truth.json).
CARD = [
    ("elevator_doublet", "de", "doublet", 0.28, 0.7, 5.5),
    ("elevator_3211", "de", "3211", 0.25, 0.4, 6.0),
    ("aileron_doublet", "da", "doublet", 0.70, 0.7, 5.5),
    ("aileron_3211", "da", "3211", 0.60, 0.4, 6.0),
    ("rudder_doublet", "dr", "doublet", 0.30, 1.0, 6.5),
    ("rudder_3211", "dr", "3211", 0.25, 0.5, 7.0),
]

# Cards: a clean one and two with one planted effect each (the specs of jsbsim_flights.SPECS).
CARDS = [
    dict(card="clean", spec="clean_s1", seed=31),
    dict(card="alpha2_CL", spec="alpha2_CL", seed=32),
    dict(card="elevator_delay", spec="elevator_delay", seed=33),
]

# The logger (sim/src/uav_log.rs `UavLogging::default`; sources in docs/test-card.md):
# channel: (rate Hz, lag s, jitter s).
GRID_HZ = 50.0
TIMING = {
    "imu": (50.0, 0.010, 0.001),
    "attitude": (25.0, 0.020, 0.002),
    "gps_velocity": (5.0, 0.200, 0.010),
    "airspeed": (10.0, 0.050, 0.005),
    "servo": (25.0, 0.0, 0.002),
    "flow_angles": (10.0, 0.020, 0.002),
    "baro": (10.0, 0.050, 0.005),
    "thrust": (10.0, 0.050, 0.005),
}
WIND_TAU_S = 30.0
WIND_ERROR_MPS = 0.5
EKF_VELOCITY_NOISE_MPS = 0.05
GPS_VELOCITY_NOISE_MPS = 0.1


def card_inputs(rec):
    _, surface, shape, amp, period, _ = rec
    f = jf.doublet if shape == "doublet" else jf.s3211

    def inputs(t, sign):
        u = sign * amp * f(t, LEAD_S, period)
        return (u if surface == "de" else 0.0, u if surface == "da" else 0.0, u if surface == "dr" else 0.0, 0.0)
    return inputs


def sample_and_hold(t_src, v, timing, n, rng):
    """Sample v(t_src) at `rate` with `lag` and uniform timestamp jitter, hold onto n grid points."""
    rate, lag, jitter = timing
    period = 1.0 / rate
    j = min(jitter, 0.25 * period)
    phase = j + (period - 2 * j) * rng.random()
    grid = np.arange(n) / GRID_HZ
    # Stamps from one period before the grid's start (so every grid point has a value).
    k = np.arange(int(math.ceil(grid[-1] * rate)) + 3)
    stamps = phase - period + k * period
    eps = j * (2 * rng.random(len(k)) - 1)
    values = np.interp(stamps - lag + eps, t_src, v)   # held at the ends, like the Rust logger
    idx = np.searchsorted(stamps, grid + 1e-9, side="right") - 1
    return values[idx]


def rotation_body_to_ned(phi, theta, psi):
    """3-2-1 Euler angles to the body→NED rotation matrices, shape (N, 3, 3)."""
    cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta), np.cos(psi), np.sin(psi)
    r = np.empty((len(phi), 3, 3))
    r[:, 0, 0] = ct * cp
    r[:, 0, 1] = sf * st * cp - cf * sp
    r[:, 0, 2] = cf * st * cp + sf * sp
    r[:, 1, 0] = ct * sp
    r[:, 1, 1] = sf * st * sp + cf * cp
    r[:, 1, 2] = cf * st * sp - sf * cp
    r[:, 2, 0] = -st
    r[:, 2, 1] = sf * ct
    r[:, 2, 2] = cf * ct
    return r


def wind_estimate(wind_ned, dt, rng):
    """First-order low-pass (τ = WIND_TAU_S) of the true horizontal wind, started on the mean wind
    (0 here), plus a constant error per horizontal axis; vertical 0 (EKF3 has no vertical wind)."""
    a = 1.0 - math.exp(-dt / WIND_TAU_S)
    err = rng.normal(0.0, WIND_ERROR_MPS, 2)
    est = np.zeros_like(wind_ned)
    state = np.zeros(2)
    for i in range(len(wind_ned)):
        est[i, :2] = state + err
        state += a * (wind_ned[i, :2] - state)
    return est


def log_record(rec, duration, elevator_lead_s, rng):
    """The small-UAV log of one JSBSim record (200 Hz) on the 50 Hz grid; CSV columns."""
    t = rec["t"]
    keep = t >= -1e-9
    r = {k: v[keep] for k, v in rec.items()}
    t = r["t"]
    N = len(t)
    n = int(round(duration * GRID_HZ))
    g = lambda s: rng.normal(0.0, s, N)
    m_kg = r["mass"] * jf.SLUG
    noise = jf.NOISE
    euler = [r["phi"] + g(noise["euler"]), r["theta"] + g(noise["euler"]), np.unwrap(r["psi"]) + g(noise["euler"])]
    vel_ned = np.column_stack([r["vn"], r["ve"], r["vd"]]) * jf.FT
    wind_ned = np.column_stack([r["wind_n"], r["wind_e"], r["wind_d"]]) * jf.FT
    w_est = wind_estimate(wind_ned, jf.DT, rng)
    v_ekf = vel_ned + rng.normal(0.0, EKF_VELOCITY_NOISE_MPS, vel_ned.shape)
    rot = rotation_body_to_ned(*euler)
    v_air_body = np.einsum("nji,nj->ni", rot, v_ekf - w_est)   # Rᵀ (v − ŵ)
    alpha_est = np.arctan2(v_air_body[:, 2], v_air_body[:, 0])
    beta_est = np.arcsin(np.clip(v_air_body[:, 1] / np.linalg.norm(v_air_body, axis=1), -1, 1))
    gps = vel_ned + rng.normal(0.0, GPS_VELOCITY_NOISE_MPS, vel_ned.shape)

    def hold(v, channel, lag_shift=0.0):
        rate, lag, jitter = TIMING[channel]
        return sample_and_hold(t, v, (rate, lag - lag_shift, jitter), n, rng)

    c = {"t_s": np.arange(n) / GRID_HZ}
    for ax in "xyz":
        c["accel_mps2_" + ax] = hold(r["fb" + ax] * jf.LBF / m_kg + g(noise["accel"]), "imu")
    for ax, p in zip("xyz", "pqr"):
        c["gyro_rad_s_" + ax] = hold(r[p] + g(noise["gyro"]), "imu")
    c["airspeed_mps"] = hold(r["vt"] * jf.FT + g(noise["airspeed"]), "airspeed")
    c["alpha_est_rad"] = hold(alpha_est, "flow_angles")
    c["beta_est_rad"] = hold(beta_est, "flow_angles")
    for ax, e in zip("xyz", euler):
        c["euler_rad_" + ax] = hold(e, "attitude")
    for i, ax in enumerate("ned"):
        c["vel_ned_mps_" + ax] = hold(gps[:, i], "gps_velocity")
    c["elevator_rad"] = hold(r["de"] + g(noise["surface"]), "servo", elevator_lead_s)
    c["aileron_rad"] = hold(-r["da_eff"] + g(noise["surface"]), "servo")
    c["rudder_rad"] = hold(r["dr"] + g(noise["surface"]), "servo")
    c["throttle"] = hold(r["thr"] + g(noise["throttle"]), "servo")
    c["air_density_kgpm3"] = hold(r["rho"] * jf.SLUGFT3 + g(noise["rho"]), "baro")
    c["thrust_n"] = hold(r["thrust"] * jf.LBF + g(noise["thrust"]), "thrust")
    c["truth_alpha_rad"] = np.interp(c["t_s"], t, r["alpha"])
    return c


FMTS = {"t_s": "%.2f", "accel_mps2_x": "%.3f", "accel_mps2_y": "%.3f", "accel_mps2_z": "%.3f",
        "gyro_rad_s_x": "%.4f", "gyro_rad_s_y": "%.4f", "gyro_rad_s_z": "%.4f", "airspeed_mps": "%.2f",
        "alpha_est_rad": "%.4f", "beta_est_rad": "%.4f", "euler_rad_x": "%.4f", "euler_rad_y": "%.4f",
        "euler_rad_z": "%.4f", "vel_ned_mps_n": "%.2f", "vel_ned_mps_e": "%.2f", "vel_ned_mps_d": "%.2f",
        "elevator_rad": "%.4f", "aileron_rad": "%.4f", "rudder_rad": "%.4f", "throttle": "%.3f",
        "air_density_kgpm3": "%.4f", "thrust_n": "%.0f", "truth_alpha_rad": "%.4f"}


def excursions(rec):
    """RMS and peak deviation of the true α, β and bank from their lead-in means, rad."""
    t = rec["t"]
    keep = t >= -1e-9
    lead = keep & (t < LEAD_S)
    out = {}
    for key, name in (("alpha", "alpha_rad"), ("beta", "beta_rad"), ("phi", "bank_rad")):
        d = rec[key][keep] - rec[key][lead].mean()
        out[name] = [round(float(np.sqrt(np.mean(d ** 2))), 5), round(float(np.abs(d).max()), 5)]
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="tool/data/jsbsim_card")
    ap.add_argument("--build", default="target/jsbsim-build")
    a = ap.parse_args()
    os.makedirs(a.build, exist_ok=True)
    os.makedirs(a.out, exist_ok=True)
    build = os.path.abspath(a.build)
    specs = {s["name"]: s for s in jf.SPECS}
    truth = {"generator": "scripts/bench/jsbsim_card.py", "jsbsim": jsbsim.__version__, "aircraft": "c172x",
             "aircraft_file": "c172x.aircraft",
             "conventions": "as tool/data/jsbsim/truth.json: body FRD; δe + TED; δa + right aileron TED; δr + TEL.",
             "flow_angles": "estimated (no vanes): alpha_est_rad, beta_est_rad from the inertial velocity minus a lagged wind estimate",
             "turbulence": "JSBSim Milspec (Dryden, MIL-F-8785C), severity %d (light), at %d ft" % (jf.TURB_SEVERITY, jf.ALT_FT),
             "logging": {"grid_hz": GRID_HZ, "resampling": "sample-and-hold",
                         **{k: {"rate_hz": v[0], "lag_s": v[1], "jitter_s": v[2]} for k, v in TIMING.items()},
                         "wind_time_constant_s": WIND_TAU_S, "wind_error_mps": WIND_ERROR_MPS,
                         "ekf_velocity_noise_mps": EKF_VELOCITY_NOISE_MPS,
                         "gps_velocity_noise_mps": GPS_VELOCITY_NOISE_MPS},
             "table_effects": jf.TABLE_EFFECTS, "cards": {}}
    for card in CARDS:
        spec = copy.deepcopy(specs[card["spec"]])
        spec["name"] = "card_" + card["card"]
        ac = jf.build_aircraft(build, spec)
        lead = spec["size"] if spec.get("post") == "elevator_lead" else 0.0
        folder = os.path.join(a.out, card["card"])
        os.makedirs(folder, exist_ok=True)
        entry = None
        if "kind" in spec:
            entry = {k: spec[k] for k in ("kind", "location", "size", "term") if k in spec}
            for k in ("terms", "accept_kinds"):
                if k in spec:
                    entry[k] = spec[k]
        records, contrib, coef_all, err = [], [], [], []
        for i, rec_def in enumerate(CARD):
            name, _, _, _, _, duration = rec_def
            seed = 100 * card["seed"] + i
            sign = 1 if i % 2 == 0 else -1
            _, rec, _ = jf.simulate(build, ac, seed, sign, duration=duration, inputs_fn=card_inputs(rec_def))
            rng = np.random.default_rng(seed)
            cols = log_record(rec, duration, lead, rng)
            n = jf.write_csv(os.path.join(folder, name + ".csv"), cols, FMTS)
            d = jf.truth_signals(rec)
            pc = jf.planted_contribution(specs[card["spec"]], d)
            if pc is not None:
                contrib.append(pc)
                coef_all.append(d)
            err.append(cols["alpha_est_rad"] - cols["truth_alpha_rad"])
            records.append({"file": "%s/%s.csv" % (card["card"], name), "manoeuvre": name, "surface": rec_def[1],
                            "shape": rec_def[2], "amplitude_norm": rec_def[3] * sign, "period_s": rec_def[4],
                            "lead_in_s": LEAD_S, "duration_s": duration, "samples": n, "seed": seed,
                            "excursions": excursions(rec)})
            print("  %-17s %s" % (name, " ".join("%s %.1f/%.1f" % (k[:-4], *np.degrees(v))
                                                  for k, v in records[-1]["excursions"].items())))
        if contrib:
            coef = spec["location"]
            pooled = {k: np.concatenate([d[k] for d in coef_all]) for k in coef_all[0]}
            pc = np.concatenate(contrib)
            X = jf.design(pooled, jf.BASE[coef])
            th, *_ = np.linalg.lstsq(X, pc, rcond=None)
            entry["rms_contribution"] = round(jf.rms(pc), 6)
            entry["rms_beyond_baseline"] = round(jf.rms(pc - X @ th), 6)
            entry["rms_coefficient"] = round(jf.rms(pooled[coef]), 6)
        e = np.concatenate(err)
        truth["cards"][card["card"]] = {"planted": entry, "seed": card["seed"], "records": records,
                                        "alpha_est_error_rms_rad": round(float(np.sqrt(np.mean(e ** 2))), 5)}
        print("%-15s %d records, %d rows; RMS(α̂ − α) %.4f rad; planted %s" % (
            card["card"], len(records), sum(r["samples"] for r in records), np.sqrt(np.mean(e ** 2)), entry))
    shutil.copy("tool/data/jsbsim/c172x.aircraft", os.path.join(a.out, "c172x.aircraft"))
    with open(os.path.join(a.out, "truth.json"), "w") as f:
        json.dump(truth, f, indent=1, ensure_ascii=False)


if __name__ == "__main__":
    main()
