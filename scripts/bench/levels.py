#!/usr/bin/env python3
"""Operating points of aerosid gaps: the benchmark campaign at several test levels.

    python3 scripts/bench/levels.py [--aerosid target/release/aerosid] [--out target/levels]
        [--draws 10] [--clean 60] [--alpha 0.001,0.01,0.03,0.1,1] [--gain-alpha 0.01,0.02,0.1,0.45]
        [-o levels.md]

Runs `aerosid gaps-bench --alpha A --gain-alpha G` for every pair (one folder each under --out)
and prints one markdown table, a row per pair: what each setting names on the simulated flights
(planted aerodynamic and sensor effects, clean flights with a cause) and on the JSBSim flights
(planted effects, table effects, spurious items per flight, invented sensor errors), scored as
score.py scores them. The default levels of `aerosid gaps` are 0.01 and 0.01. A campaign in
which a flight fails is listed as failed, not scored, and the script then exits non-zero.

Reads nothing but the aerosid binary's output (standard library only, no venv).
"""
import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from score import fmt_frac, score_method  # noqa: E402


def floats(text):
    return [float(x) for x in text.split(",") if x]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--aerosid", default="target/release/aerosid")
    ap.add_argument("--out", default="target/levels")
    ap.add_argument("--draws", type=int, default=10, help="simulated flights per hidden kind")
    ap.add_argument("--clean", type=int, default=60, help="simulated clean flights")
    ap.add_argument("--alpha", type=floats, default=floats("0.001,0.01,0.03,0.1,1"))
    ap.add_argument("--gain-alpha", type=floats, default=floats("0.01,0.02,0.1,0.45"))
    ap.add_argument("-o", help="also write the table to this file")
    a = ap.parse_args()
    head = ["--alpha", "--gain-alpha", "sim: planted aero", "sim: planted sensor", "sim: clean with a cause",
            "JSBSim: planted aero", "JSBSim: planted sensor", "JSBSim: table effects", "JSBSim: spurious / flight",
            "JSBSim: invented sensor errors"]
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    failed = []
    for alpha in a.alpha:
        for gain in a.gain_alpha:
            out = os.path.join(a.out, "a%r_g%r" % (alpha, gain))
            cmd = [a.aerosid, "gaps-bench", "--draws", str(a.draws), "--clean", str(a.clean),
                   "--alpha", repr(alpha), "--gain-alpha", repr(gain), "--out", out]
            run = subprocess.run(cmd, capture_output=True, text=True)
            # gaps-bench leaves a flight that failed out of the manifest and prints ERROR for it:
            # such a campaign is not scored (a smaller denominator would hide the failure).
            errors = [l for l in run.stdout.splitlines() if " ERROR " in l]
            if run.returncode != 0 or errors:
                failed.append(" ".join(cmd))
                print("%s failed:\n%s%s" % (" ".join(cmd), run.stderr, "\n".join(errors)), file=sys.stderr)
                rows.append("| %g | %g | failed |" % (alpha, gain) + " |" * (len(head) - 3))
                continue
            flights = json.load(open(os.path.join(out, "manifest.json")))
            sim = score_method([f for f in flights if f.get("suite") == "sim"], named_by_aerosid)
            jsb = score_method([f for f in flights if f.get("suite") == "jsbsim"], named_by_aerosid)
            spurious = "%.1f" % (sum(jsb["spurious"]) / len(jsb["spurious"])) if jsb["spurious"] else "–"
            row = ["%g" % alpha, "%g" % gain,
                   fmt_frac(sim["aero_hit"], sim["aero_n"]), fmt_frac(sim["sens_hit"], sim["sens_n"]),
                   fmt_frac(sim["clean_named"], sim["clean_n"]),
                   fmt_frac(jsb["aero_hit"], jsb["aero_n"]), fmt_frac(jsb["sens_hit"], jsb["sens_n"]),
                   fmt_frac(jsb["table_named"], jsb["table_total"]), spurious, str(sum(jsb["invented"]))]
            rows.append("| " + " | ".join(row) + " |")
            print(rows[-1], file=sys.stderr)
    text = "\n".join(rows) + "\n"
    print(text, end="")
    if a.o:
        open(a.o, "w").write(text)
    if failed:
        sys.exit("%d campaign(s) failed: %s" % (len(failed), "; ".join(failed)))



def named_by_aerosid(flight):
    """What aerosid named on a manifest flight (score.py's per-method accessor)."""
    return flight.get("aerosid")


if __name__ == "__main__":
    main()
