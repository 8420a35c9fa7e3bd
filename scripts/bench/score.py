#!/usr/bin/env python3
"""Score aerosid gaps against the peers (STLSQ, FROLS) on a benchmark manifest.

    target/venv/bin/python scripts/bench/score.py MANIFEST.json [PEERS.json ...] [-o score.md]

Reads the manifest (each flight's "planted", optional "table_effects", and the Rust side's
"aerosid": {"named": [{"kind","location","what"}], "seconds"}) and one or more peers files
(peers.py; default peers.json next to the manifest), and prints one markdown table per suite with
one row per peer configuration found (every key of a flight's "peers"), labelled with its settings.

Matching (a named item = {kind, location, term}; aerosid's term is its "what"):
  * planted effect named: some named item has the planted location and the planted kind (or one of
    the planted "accept_kinds") and, when the effect lists "terms", one of those terms (a kind that
    also covers other effects at that location: a gyroscopic r̂ in C_m is CrossCoupling, as is the
    planted β²; the terms are the library's names, which the peers share). A planted ControlDelay on the channel "Elevator" is also matched by
    a ControlDelay named in C_L, C_D or C_m (a δė term: how a regression names a surface delay) and
    by a TimeDelay on "Elevator". Sensor kinds: SensorBias, ScaleFactor, ControlDelay, TimeDelay,
    VanePosition; the rest are aerodynamic.
  * clean flight with a cause: a flight with "planted": [] where anything is named; named / clean
    flight: mean items named on those flights.
  * table effect named (jsbsim): a named item, not matching a planted effect, whose location and
    kind equal a listed table effect, and its term one of the effect's "terms" when listed (each
    listed effect counted once per flight). A table effect
    of kind NonlinearBeta is also matched by CrossCoupling (the manifest's kind for |β|, β² in
    C_L/C_D/C_m; the same equivalence the planted β² effect carries in accept_kinds).
  * spurious: a named item that matches neither a planted effect nor a table effect.
  * invented sensor error: a named item of a sensor kind that matches no planted effect.
Flights with "planted": null (unknown truth) count only in "named per flight" and time.

Pooled-manoeuvre suites (entries with "pooled": the test cards of `aerosid gaps-bench --cards N`)
get a second table (pooled_section): each planted effect is compared with the least size the
campaign detects: the oracle's `oracle_min_detectable` of the planted term's candidate in the
campaign's own report when the report has it, else the tool's `min_detectable` (the aerodynamic
term in its coefficient, or the sensor parameter in the compatibility check), where the planted
size is in that parameter's unit (EFFECT_PARAM); detection is scored over the effects with
|size| >= 1.5 times that limit, those below and those with no comparable limit are
counted apart; plus a sensor cause on an aerodynamic plant or the reverse, the order check (the
same causes with the files reversed) and one manoeuvre alone (no cause, with a reason). The peers
are compared at their operating point: of each peer's configurations, those with at most 1 clean
campaign in 10 with a cause; the one detecting most of them is shown.

With --truth, campaigns whose logs carry the true flow angles (truth_alpha_rad, truth_beta_rad)
get a fourth: the oracle's reliability ratio of α² (C_L), α·β (C_l), β² (C_m) and the angles'
error it took (the report's note) against those measured from the truth (reliability_section).

Every suite whose reports carry the oracle gets a third table (se_ratio_section): per candidate
family (an aerodynamic candidate's kind in its coefficient; a sensor parameter's kind and the part
that scored it) the distribution of `se_ratio` = the tool's σ over the oracle's standard error,
over every scored candidate of every report (goal: <= 1.5), and a line naming the families whose
median or 90th percentile is above the goal. For those families, on every suite but the real
flights, a fourth (scatter_section): each term's estimates over the flights where nothing planted
moves it — their standard deviation against the RMS of the tool's σ and (aerodynamic candidates,
whose oracle is the same estimate) of the oracle's — which says whether a high ratio is the tool's
σ too large or the oracle's too small.
"""
import argparse
import json
import os
import re
import statistics
import sys

SENSOR = {"SensorBias", "ScaleFactor", "ControlDelay", "TimeDelay", "VanePosition"}
LONG = {"C_L", "C_D", "C_m"}


def term_of(item):
    return item.get("term") or item.get("what")


def term_ok(item, effect):
    terms = effect.get("terms")
    return not terms or term_of(item) in terms


def matches_planted(item, p):
    kinds = set(p.get("accept_kinds") or []) | {p["kind"]}
    if item["location"] == p["location"] and item["kind"] in kinds and term_ok(item, p):
        return True
    if p["kind"] == "ControlDelay" and p["location"] == "Elevator":
        if item["kind"] == "ControlDelay" and item["location"] in LONG:
            return True
        if item["kind"] == "TimeDelay" and item["location"] == "Elevator":
            return True
    return False


TABLE_EQUIV = {"NonlinearBeta": {"NonlinearBeta", "CrossCoupling"}}


def matches_table(item, effects):
    return [i for i, e in enumerate(effects or [])
            if item["kind"] in TABLE_EQUIV.get(e.get("kind"), {e.get("kind")}) and e["location"] == item["location"]
            and term_ok(item, e)]


def dedupe(named):
    seen, out = set(), []
    for n in named:
        k = (n["kind"], n["location"], n.get("term") or n.get("what"))
        if k not in seen:
            seen.add(k)
            out.append(n)
    return out


def score_method(flights, getter):
    s = dict(aero_hit=0, aero_n=0, sens_hit=0, sens_n=0, clean_named=0, clean_n=0, named=[], secs=[],
             table_named=0, table_total=0, spurious=[], invented=[], has_table=False, clean_items=[], cpu=[])
    for fl in flights:
        res = getter(fl)
        if res is None:
            continue
        named = dedupe(res.get("named", []))
        s["named"].append(len(named))
        if res.get("seconds") is not None:
            s["secs"].append(float(res["seconds"]))
        if res.get("cpu_seconds") is not None:
            s["cpu"].append(float(res["cpu_seconds"]))
        planted = fl.get("planted")
        effects = fl.get("table_effects")
        if effects is not None:
            s["has_table"] = True
            hit_effects = set()
            for n in named:
                if not any(matches_planted(n, p) for p in (planted or [])):
                    hit_effects.update(matches_table(n, effects))
            s["table_named"] += len(hit_effects)
            s["table_total"] += len(effects)
        if planted is None:
            continue
        for p in planted:
            hit = any(matches_planted(n, p) for n in named)
            key = "sens" if p["kind"] in SENSOR else "aero"
            s[key + "_n"] += 1
            s[key + "_hit"] += hit
        if not planted:
            s["clean_n"] += 1
            s["clean_named"] += bool(named)
            s["clean_items"].append(len(named))
        spur = [n for n in named if not any(matches_planted(n, p) for p in planted) and not matches_table(n, effects)]
        s["spurious"].append(len(spur))
        s["invented"].append(sum(1 for n in named if n["kind"] in SENSOR and not any(matches_planted(n, p) for p in planted)))
    return s


# The planted size is the coefficient of this term (aerodynamic: location, term) or this sensor
# parameter (kind, channel) — the same unit as that candidate's min_detectable. Kinds missing here
# have no candidate in the size's unit: thrust-moment (a propeller offset in m, not C_T's
# coefficient), missing-roll-control (the aircraft's own C_l δa, size 0 in the manifest).
EFFECT_PARAM = {
    "lift-quadratic": ("coef", "α²"),
    "elevator-drag": ("coef", "|δe|"),
    "alpha-dot": ("coef", "α̇_n"),
    "cross-coupling": ("coef", "α·β"),
    "pitch-beta2": ("coef", "β²"),
    "adverse-yaw": ("coef", "δa"),
    "sensor-bias": ("sensor", "SensorBias"),
    "elevator-delay": ("delay", "C_m"),
}
DETECT_FACTOR = 1.5
SE_RATIO_GOAL = 1.5


def limit_of(d):
    """(least detectable size, which) of a candidate entry of report.json: the oracle's when the
    report has it, else the tool's own."""
    if d.get("oracle_min_detectable") is not None:
        return d["oracle_min_detectable"], "oracle"
    return d.get("min_detectable"), "tool"


def effect_of(p):
    """The effect's name (EFFECT_PARAM's key): the manifest's `effect`, or for the JSBSim cards
    (truth.json's planted: kind, location, term) the simulated kind it corresponds to."""
    if p.get("effect"):
        return p["effect"]
    if p.get("kind") == "NonlinearAlpha" and p.get("location") == "C_L" and p.get("term") == "α²":
        return "lift-quadratic"
    if p.get("kind") == "ControlDelay" and p.get("location") == "Elevator":
        return "elevator-delay"
    return None


def planted_limit(p, report):
    """(least detectable size, t2, estimate, what) of the planted effect's own parameter in the
    report (limit_of: the oracle's when present, else min_detectable; `what` says which), or None
    when the planted size has no parameter of its unit (EFFECT_PARAM) or the report lacks it."""
    how = EFFECT_PARAM.get(effect_of(p))
    if how is None or report is None:
        return None
    if how[0] == "delay":
        # A surface delay τ enters as δe(t − τ) ≈ δe − τ·δė (the analysis's own first-order
        # reading): the δė candidate's coefficient is −C_δe·τ, so τ's least detectable size is
        # min_detectable(δė) / |C_δe| in the coefficient where the analysis converts it.
        for c in report.get("coefficients", []):
            if c.get("name") != how[1]:
                continue
            de = [q.get("value") for q in (c.get("baseline") or {}).get("parameters", []) if q.get("term") == "δe"]
            for cand in c.get("candidates", []):
                md, which = limit_of(cand)
                if cand.get("term") == "δė" and de and de[0] and md is not None:
                    return (md / abs(de[0]), cand.get("t2"),
                            (cand.get("value") or 0.0) / -de[0] if cand.get("value") is not None else None,
                            "%s δė / |C δe| (%s)" % (how[1], which))
        return None
    if how[0] == "coef":
        for c in report.get("coefficients", []):
            if c.get("name") != p["location"]:
                continue
            for cand in c.get("candidates", []):
                if cand.get("term") == how[1]:
                    md, which = limit_of(cand)
                    return (md, cand.get("t2"), cand.get("value"), "%s %s (%s)" % (p["location"], how[1], which))
        return None
    for t in report.get("compatibility", {}).get("tested", []):
        if t.get("kind") == how[1] and t.get("channel") == p["location"]:
            md, which = limit_of(t)
            return (md, t.get("t2"), t.get("value"), "%s (%s)" % (t.get("parameter"), which))
    return None


def se_ratios(report):
    """{family: [se_ratio, ...]} over the scored candidates of one report.json."""
    out = {}
    for c in report.get("coefficients", []):
        for cand in c.get("candidates", []):
            if cand.get("se_ratio") is not None:
                out.setdefault("%s %s" % (c.get("name"), cand.get("kind")), []).append(cand["se_ratio"])
    for t in report.get("compatibility", {}).get("tested", []):
        if t.get("se_ratio") is not None:
            out.setdefault("%s (%s)" % (t.get("kind"), t.get("part")), []).append(t["se_ratio"])
    return out


# The flow-angle terms whose attenuation the truth columns of a simulated campaign measure:
# (report coefficient, term, the measured term from a log row, the true one, the baseline's columns).
ANGLE_TERMS = [
    ("C_L", "α²", lambda r: r["alpha_est_rad"] ** 2, lambda r: r["truth_alpha_rad"] ** 2, "lon"),
    ("C_l", "α·β", lambda r: r["alpha_est_rad"] * r["beta_est_rad"],
     lambda r: r["truth_alpha_rad"] * r["truth_beta_rad"], "lat"),
    ("C_m", "β²", lambda r: r["beta_est_rad"] ** 2, lambda r: r["truth_beta_rad"] ** 2, "lon"),
]
BASELINE_COLUMNS = {
    "lon": ["alpha_est_rad", "gyro_rad_s_y", "elevator_rad"],
    "lat": ["beta_est_rad", "gyro_rad_s_x", "gyro_rad_s_z", "aileron_rad", "rudder_rad"],
}


def residual_on(cols, y):
    """y less its least-squares fit on an intercept and `cols` (normal equations, Gauss-Jordan with
    partial pivoting: at most 6 columns)."""
    xs = [[1.0] * len(y)] + cols
    k = len(xs)
    a = [[sum(p * q for p, q in zip(xs[i], xs[j])) for j in range(k)] + [sum(p * q for p, q in zip(xs[i], y))]
         for i in range(k)]
    for c in range(k):
        piv = max(range(c, k), key=lambda r: abs(a[r][c]))
        a[c], a[piv] = a[piv], a[c]
        if a[c][c] == 0:
            return None
        for r in range(k):
            if r != c:
                f = a[r][c] / a[c][c]
                a[r] = [x - f * z for x, z in zip(a[r], a[c])]
    th = [a[i][k] / a[i][i] for i in range(k)]
    return [y[n] - sum(th[j] * xs[j][n] for j in range(k)) for n in range(len(y))]


def truth_reliability(fl):
    """{(coefficient, term): λ} measured from a campaign's logs that carry the true flow angles, and
    {("σ", angle): the standard deviation of estimate − truth over all the samples}: λ is the
    slope of the true term's part not explained by the baseline's columns on the measured term's
    (regression calibration, Fuller 1987 §1.1: the factor by which a fit on the measured term
    attenuates the true coefficient). Terms needing a truth column the logs lack are left out."""
    import csv
    import glob
    toks = (fl.get("reproduce") or "").split()
    files = sorted(f for i, t in enumerate(toks[:-1]) if t == "--data" for f in glob.glob(toks[i + 1]))
    rows = []
    for f in files:
        if not f.endswith(".csv") or not os.path.exists(f):
            return {}
        reader = csv.DictReader(open(f))
        if not any(k.startswith("truth_") for k in reader.fieldnames or []):
            return {}
        try:
            rows += [{k: float(v) for k, v in r.items() if v not in ("", None)} for r in reader]
        except ValueError:
            return {}
    out = {}
    for q, sym in (("alpha", "α"), ("beta", "β")):
        e = [r[q + "_est_rad"] - r["truth_%s_rad" % q] for r in rows if "truth_%s_rad" % q in r and q + "_est_rad" in r]
        if len(e) > 1:
            out[("σ", sym)] = statistics.pstdev(e)
    for coef, term, meas, true, side in ANGLE_TERMS:
        if not rows or any("truth_" + t not in rows[0] or t.replace("_rad", "_est_rad") not in rows[0]
                           for t in term_truth(term)):
            continue
        try:
            cols = [[r[c] for r in rows] for c in BASELINE_COLUMNS[side]]
            um = residual_on(cols, [meas(r) for r in rows])
            ut = residual_on(cols, [true(r) for r in rows])
        except KeyError:
            continue
        if um and ut:
            ss = sum(x * x for x in um)
            if ss > 0:
                out[(coef, term)] = sum(x * y for x, y in zip(um, ut)) / ss
    return out


def term_truth(term):
    """The truth columns' suffixes a term needs."""
    return [n for n, sym in (("alpha_rad", "α"), ("beta_rad", "β")) if sym in term]


def reliability_section(suite, fs, base):
    """Markdown: the oracle's reliability ratio of each flow-angle term against the one measured
    from the logs' true angles (campaigns whose logs carry them)."""
    rows = []
    for fl in fs:
        meas = truth_reliability(fl)
        path = report_path(fl, base)
        if not meas or not path:
            continue
        report = json.load(open(path))
        taken = {}
        for note in report.get("notes", []):
            m = re.search(r"error taken as (.*?) \(the force", note)
            for sym, v in re.findall(r"(α|β) \(from C_[LY]\) ([0-9.eE+-]+) rad", m.group(1)) if m else []:
                taken[sym] = float(v)
        for sym in ("α", "β"):
            if ("σ", sym) in meas:
                rows.append("| %s | σ of the estimated %s, rad | %s | %.4f |" % (
                    fl["id"], sym, "%.4f" % taken[sym] if sym in taken else "–", meas.pop(("σ", sym))))
        for (coef, term), lam in sorted(meas.items()):
            cand = [k for c in report.get("coefficients", []) if c.get("name") == coef
                    for k in c.get("candidates", []) if k.get("term") == term]
            lo = cand[0].get("oracle_reliability") if cand else None
            rows.append("| %s | %s %s | %s | %.3f |" % (fl["id"], coef, term, "%.3f" % lo if lo is not None else "–", lam))
    if not rows:
        return []
    return ["#### `%s`: reliability of the flow-angle terms, the oracle's λ against the logs' truth\n" % suite,
            "| campaign | term | the oracle's | measured (true angles) |", "|---|---|---|---|"] + rows + [""]


def report_path(fl, base):
    """The flight's report.json: the manifest's "report", else reports/<id>.json (the single
    flights' reports, written under their id with "/" as "_"), or None."""
    rel = fl.get("report") or os.path.join("reports", fl["id"].replace("/", "_") + ".json")
    path = os.path.join(base, rel)
    return path if os.path.exists(path) else None


def se_ratio_section(suite, fs, base):
    """Markdown: the distribution of se_ratio per candidate family over the suite's reports."""
    fam = {}
    for fl in fs:
        path = report_path(fl, base)
        if not path:
            continue
        for k, v in se_ratios(json.load(open(path))).items():
            fam.setdefault(k, []).extend(v)
    if not fam:
        return []
    out = ["#### `%s`: the tool's σ over the oracle's standard error (se_ratio), per candidate family\n" % suite]
    head = ["family", "candidates", "median", "90th percentile", "max", "share <= %.1f" % SE_RATIO_GOAL]
    out.append("| " + " | ".join(head) + " |")
    out.append("|" + "---|" * len(head))
    above = []
    for k in sorted(fam):
        v = sorted(fam[k])
        p90 = v[min(len(v) - 1, int(0.9 * len(v)))]
        share = sum(1 for x in v if x <= SE_RATIO_GOAL) / len(v)
        out.append("| %s | %d | %.2f | %.2f | %.2f | %.0f %% |" % (k, len(v), statistics.median(v), p90, v[-1], 100 * share))
        if max(statistics.median(v), p90) > SE_RATIO_GOAL:
            above.append("%s (%d)" % (k, len(v)))
    out.append("")
    out.append("* families with the median or the 90th percentile above %.1f: %d of %d%s" % (
        SE_RATIO_GOAL, len(above), len(fam), (": " + ", ".join(above)) if above else ""))
    out.append("")
    return out


def scatter_estimates(report, skip):
    """{(family, term): [(value, sigma, oracle_se), ...]} over the scored candidates of one
    report.json, leaving out the coefficients (aerodynamic) or the sensor candidates ("sensor") in
    `skip`: those where the flight's planted effect moves the estimate."""
    out = {}
    for c in report.get("coefficients", []):
        if c.get("name") in skip:
            continue
        for cand in c.get("candidates", []):
            if cand.get("se_ratio") is not None and cand.get("value") is not None:
                key = ("%s %s" % (c.get("name"), cand.get("kind")), cand.get("term"))
                out.setdefault(key, []).append((cand["value"], cand["sigma"], cand["oracle_se"]))
    if "sensor" not in skip:
        for t in report.get("compatibility", {}).get("tested", []):
            if t.get("se_ratio") is not None and t.get("value") is not None:
                key = ("%s (%s)" % (t.get("kind"), t.get("part")), t.get("parameter"))
                out.setdefault(key, []).append((t["value"], t["sigma"], t["oracle_se"]))
    return out


# Estimates of one term over at least this many flights of a suite enter the scatter check.
SCATTER_MIN_FLIGHTS = 8


def scatter_section(suite, fs, base):
    """Markdown: for the families above the se_ratio goal, each term's estimates over the suite's
    flights of one aircraft against the σ that claims to bound them. On flights where nothing
    planted moves a term, its estimates differ by their errors and by what differs between the
    flights (the draw of the turbulence and of the manoeuvres' noise): their standard deviation
    is at least the estimate's true standard error, so a σ far below it is too small (a ratio
    near 1 or below: the σ is honest or conservative). The mean is an offset no σ of one flight
    shows. Which side of a high se_ratio is wrong: the tool's σ (scatter / σ_tool well below 1) or
    the oracle's (scatter / oracle well above 1). The latter only where the oracle's estimate is
    the tool's first-round one (the aerodynamic candidates): a sensor candidate's oracle is the
    reconstruction's σ of its own, different estimate (its check is eks.rs's clean-flight test),
    so there the column is left empty."""
    fam = {}
    for fl in fs:
        path = report_path(fl, base)
        planted = fl.get("planted")
        if not path or planted is None:
            continue
        skip = {p.get("location") for p in planted}
        if any(p.get("kind") in SENSOR for p in planted):
            skip.add("sensor")
        for k, v in se_ratios(json.load(open(path))).items():
            fam.setdefault(k, []).extend(v)
        for k, v in scatter_estimates(json.load(open(path)), skip).items():
            fam.setdefault(k, []).extend(v)
    above = set()
    for k, v in fam.items():
        if isinstance(k, str):
            v = sorted(v)
            p90 = v[min(len(v) - 1, int(0.9 * len(v)))]
            if max(statistics.median(v), p90) > SE_RATIO_GOAL:
                above.add(k)
    rows = sorted(k for k in fam if isinstance(k, tuple) and k[0] in above and len(fam[k]) >= SCATTER_MIN_FLIGHTS)
    if not rows:
        return []
    out = ["#### `%s`: the families above the goal, each term's scatter over the flights against the σ\n" % suite]
    head = ["family", "term", "flights", "mean", "scatter (sd)", "RMS σ tool", "scatter / σ tool", "RMS oracle", "scatter / oracle"]
    out.append("| " + " | ".join(head) + " |")
    out.append("|" + "---|" * len(head))
    rms = lambda xs: (sum(x * x for x in xs) / len(xs)) ** 0.5
    for k in rows:
        v = fam[k]
        sd = statistics.stdev(x[0] for x in v)
        st, so = rms([x[1] for x in v]), rms([x[2] for x in v])
        sensor = k[0].endswith(")")
        out.append("| %s | %s | %d | %.3g | %.3g | %.3g | %.2f | %.3g | %s |" % (
            k[0], k[1], len(v), statistics.mean(x[0] for x in v), sd, st, sd / st, so,
            "–" if sensor else "%.2f" % (sd / so)))
    out.append("")
    return out


def pooled_rows(flights, getter, base):
    """Counts of one method on a pooled suite (see the module doc)."""
    r = dict(det_hit=0, det_n=0, below_hit=0, below_n=0, nc_hit=0, nc_n=0, clean_named=0, clean_n=0,
             det_aero_hit=0, det_aero_n=0, det_sens_hit=0, det_sens_n=0,
             cross=0, cross_n=0, cross_items=[], order_ok=0, order_n=0, single_ok=0, single_n=0, misses=[], below=[])
    for fl in flights:
        res = getter(fl)
        planted = fl.get("planted")
        if res is None or planted is None:
            continue
        named = dedupe(res.get("named", []))
        if not planted:
            r["clean_n"] += 1
            r["clean_named"] += bool(named)
        report = None
        path = report_path(fl, base)
        if path and os.path.exists(path):
            report = json.load(open(path))
        for p in planted:
            hit = any(matches_planted(n, p) for n in named)
            # A single simulated flight's id names its kind ("sim/lift-quadratic_20001").
            if not p.get("effect") and fl.get("suite") == "sim":
                p = dict(p, effect=fl["id"].split("/", 1)[-1].rsplit("_", 1)[0])
            lim = planted_limit(p, report)
            size = p.get("size")
            md = lim[0] if lim else None
            if md is None or size is None:
                key = "nc"
            elif abs(size) >= DETECT_FACTOR * md:
                key = "det"
            else:
                key = "below"
            r[key + "_n"] += 1
            r[key + "_hit"] += hit
            sensor = p["kind"] in SENSOR
            if key == "det":
                r["det_%s_n" % ("sens" if sensor else "aero")] += 1
                r["det_%s_hit" % ("sens" if sensor else "aero")] += hit
            r["cross_n"] += 1
            # A known table effect of the aircraft (JSBSim's CDbeta in C_D) is its truth, not a
            # cause of the other category.
            other = [n for n in named if (n["kind"] in SENSOR) != sensor and not matches_planted(n, p)
                     and not matches_table(n, fl.get("table_effects"))]
            r["cross"] += bool(other)
            if other:
                r["cross_items"].append("%s: %s" % (fl["id"], "; ".join("%s %s %s" % (n["kind"], n["location"], term_of(n)) for n in other)))
            info = dict(id=fl["id"], size=size, limit=lim,
                        named=["%s %s %s" % (n["kind"], n["location"], term_of(n)) for n in named])
            if key == "det" and not hit:
                r["misses"].append(info)
            if key == "below":
                r["below"].append(dict(info, hit=hit))
        pooled = fl.get("pooled")
        if pooled is not None and getter(fl) is fl.get("aerosid"):
            r["order_n"] += 1
            r["order_ok"] += bool(pooled["reversed"].get("same_causes"))
            single = pooled["single_manoeuvre"]
            r["single_n"] += 1
            r["single_ok"] += (not single.get("named")) and bool(single.get("error") or single.get("verdict"))
    return r


def pooled_section(suite, fs, methods, base):
    """Markdown: the pooled suite's detection relative to min_detectable, per method, then the
    peers at their operating point and aerosid's misses."""
    out = ["#### `%s`: detection relative to the least detectable size\n" % suite]
    head = ["method", "named, size >= %.1fx the least detectable size" % DETECT_FACTOR, "named, below", "named, no comparable limit",
            "clean campaigns with a cause", "cause of the other category", "same causes reversed",
            "one manoeuvre alone: no cause, with reason"]
    out.append("| " + " | ".join(head) + " |")
    out.append("|" + "---|" * len(head))
    rows = {}
    for name, g in methods:
        r = pooled_rows(fs, g, base)
        rows[name] = r
        if r["clean_n"] + r["det_n"] + r["below_n"] + r["nc_n"] == 0:
            continue
        out.append("| " + " | ".join([name, fmt_frac(r["det_hit"], r["det_n"]), fmt_frac(r["below_hit"], r["below_n"]),
                                       fmt_frac(r["nc_hit"], r["nc_n"]), fmt_frac(r["clean_named"], r["clean_n"]),
                                       fmt_frac(r["cross"], r["cross_n"]), fmt_frac(r["order_ok"], r["order_n"]),
                                       fmt_frac(r["single_ok"], r["single_n"])]) + " |")
    out.append("")
    # Operating point: per peer, the configurations with <= 1 clean campaign in 10 with a cause.
    families = {}
    for name, _ in methods[1:]:
        if name in SWEEP_LABELS:
            continue
        families.setdefault(name.split(" (")[0].split(" @")[0].split()[0], []).append(name)
    for fam, names in families.items():
        ok = [n for n in names if rows[n]["clean_n"] and rows[n]["clean_named"] <= 0.1 * rows[n]["clean_n"]]
        if ok:
            best = max(ok, key=lambda n: (rows[n]["det_hit"], -rows[n]["clean_named"]))
            out.append("* %s at <= 1 clean campaign in 10 with a cause: %s — %s of the effects >= %.1fx the least detectable size"
                       % (fam, best, fmt_frac(rows[best]["det_hit"], rows[best]["det_n"]), DETECT_FACTOR))
        elif names:
            low = min(names, key=lambda n: rows[n]["clean_named"] / max(rows[n]["clean_n"], 1))
            out.append("* %s: no configuration reaches <= 1 clean campaign in 10 with a cause (fewest: %s, %s)"
                       % (fam, low, fmt_frac(rows[low]["clean_named"], rows[low]["clean_n"])))
    a = rows[methods[0][0]]
    for title, items in (("aerosid misses (size >= %.1fx the least detectable size)" % DETECT_FACTOR, a["misses"]),
                         ("below %.1fx the least detectable size" % DETECT_FACTOR, a["below"])):
        if items:
            out.append("\n%s:\n" % title)
            for m in items:
                lim = m["limit"]
                f = lambda x: "%.4g" % x if isinstance(x, (int, float)) else "–"
                out.append("* %s: size %s, %s limit %s (ratio %s), t² %s, estimate %s%s; named: %s" % (
                    m["id"], f(m["size"]), lim[3], f(lim[0]),
                    f(abs(m["size"]) / lim[0]) if lim[0] else "–", f(lim[1]), f(lim[2]),
                    (", named it" if m.get("hit") else (", missed" if "hit" in m else "")),
                    "; ".join(m["named"]) or "nothing"))
    if a["cross_items"]:
        out.append("\naerosid, a cause of the other category (sensor on an aerodynamic plant or the reverse):\n")
        out += ["* " + x for x in a["cross_items"]]
    out.append("")
    return out


# Peers at an equal false-alarm rate (peers.py --sweep): per suite and sweep, the most permissive
# knob value at which at most FA_RATE of the clean flights have a false alarm.
FA_RATE = 0.1
SWEEP_LABELS = set()


def false_alarm(fl, named):
    """A clean flight (planted []) with an item named that is not one of its aircraft's listed
    table effects (JSBSim: the table effects are truth, not alarms); elsewhere any item."""
    return any(not matches_table(n, fl.get("table_effects")) for n in named)


def sweep_named_at(rec, i):
    """The items a sweep's record (peers.json flight -> sweeps -> key) names at grid index i."""
    return [{"location": rec["items"][j][0], "term": rec["items"][j][1], "kind": rec["items"][j][2]}
            for j in rec["path"][i]]


def operating_point(fs, recs, grid):
    """(index, reached, false alarms, clean flights) of a sweep on one suite: the first (most
    permissive) grid index with at most FA_RATE of the clean flights with a false alarm; when none
    reaches it, the index with the fewest (the least permissive on a tie) and reached False.
    None when the suite has no clean flight or no sweep record."""
    clean = [f for f in fs if f.get("planted") == [] and f["id"] in recs]
    if not clean:
        return None
    counts = [sum(false_alarm(f, sweep_named_at(recs[f["id"]], i)) for f in clean) for i in range(len(grid))]
    for i, c in enumerate(counts):
        if c <= FA_RATE * len(clean):
            return i, True, c, len(clean)
    i = min(range(len(grid)), key=lambda i: (counts[i], -i))
    return i, False, counts[i], len(clean)


def equal_fa_section(suite, fs, aerosid, sweeps, base):
    """Markdown: aerosid at its defaults and every swept peer at its equal-false-alarm point, one row
    per figure. sweeps: [(label, settings, {id: record}, point)]."""
    cols = [("aerosid gaps (defaults)", aerosid)]
    for label, st, recs, pt in sweeps:
        if pt is None:
            continue
        cols.append((label, (lambda recs, i: lambda fl: None if fl["id"] not in recs else dict(
            named=sweep_named_at(recs[fl["id"]], i), seconds=recs[fl["id"]].get("seconds"),
            cpu_seconds=recs[fl["id"]].get("cpu_seconds")))(recs, pt[0])))
    if len(cols) == 1:
        return []
    sc = [score_method(fs, g) for _, g in cols]
    pr = [pooled_rows(fs, g, base) for _, g in cols]
    clean = [f for f in fs if f.get("planted") == []]
    fa = [sum(false_alarm(f, dedupe((g(f) or {}).get("named", []))) for f in clean) for _, g in cols]
    table = any(s["has_table"] for s in sc)
    sized = any(any("size" in p for p in f.get("planted") or []) or f.get("pooled") is not None for f in fs)
    point = ["default (`--alpha 0.01 --gain-alpha 0.01`)"]
    for label, st, recs, pt in sweeps:
        if pt is None:
            continue
        v = "%s %.3g" % (st["knob"], st["grid"][pt[0]])
        point.append(v if pt[1] else "not reached: sweep's end %s %.3g of %.3g–%.3g" % (
            st["knob"], st["grid"][pt[0]], st["grid"][0], st["grid"][-1]))
    rows = [("operating point", point),
            ("clean flights with a false alarm%s (the rate compared: ≤ 1 in 10)" % (
                " (an item not among the aircraft's table effects)" if table else " (any cause)"),
             [fmt_frac(a, len(clean)) for a in fa]),
            ("planted aerodynamic effects named with the right cause", [fmt_frac(s["aero_hit"], s["aero_n"]) for s in sc])]
    if sized:
        rows += [("planted aerodynamic effects ≥ %.1f× the oracle's limit named" % DETECT_FACTOR,
                  [fmt_frac(r["det_aero_hit"], r["det_aero_n"]) for r in pr]),
                 ("planted sensor effects ≥ %.1f× the oracle's limit named" % DETECT_FACTOR,
                  [fmt_frac(r["det_sens_hit"], r["det_sens_n"]) for r in pr]),
                 ("planted effects below %.1f× the limit named" % DETECT_FACTOR, [fmt_frac(r["below_hit"], r["below_n"]) for r in pr]),
                 ("planted effects with no limit in the size's unit named", [fmt_frac(r["nc_hit"], r["nc_n"]) for r in pr])]
    rows += [("planted sensor effects named", [fmt_frac(s["sens_hit"], s["sens_n"]) for s in sc]),
             ("a cause of the other category (sensor on an aerodynamic plant or the reverse)",
              [fmt_frac(r["cross"], r["cross_n"]) for r in pr]),
             ("items named per clean flight", ["%.1f" % statistics.mean(s["clean_items"]) if s["clean_items"] else "–" for s in sc])]
    if table:
        rows += [("table effects named", [fmt_frac(s["table_named"], s["table_total"]) for s in sc]),
                 ("spurious items per flight", ["%.1f" % statistics.mean(s["spurious"]) if s["spurious"] else "–" for s in sc])]
    rows.append(("CPU s per flight, median (the peers: the whole sweep)",
                 ["%.3g" % statistics.median(s["cpu"]) if s["cpu"] else "–" for s in sc]))
    out = ["#### `%s`: at an equal false-alarm rate (each peer's knob at its most permissive value with ≤ 1 clean "
           "flight in 10 with a false alarm, chosen on these clean flights)\n" % suite,
           "| figure | " + " | ".join(n for n, _ in cols) + " |", "|---|" + "---:|" * len(cols)]
    out += ["| %s | %s |" % (name, " | ".join(v)) for name, v in rows]
    out.append("")
    return out


def sweep_curve(suite, fs, sweeps):
    """Markdown lines: each sweep's false alarms along its grid on this suite (the choice shown)."""
    out = []
    for label, st, recs, pt in sweeps:
        clean = [f for f in fs if f.get("planted") == [] and f["id"] in recs]
        if not clean or pt is None:
            continue
        counts = [sum(false_alarm(f, sweep_named_at(recs[f["id"]], i)) for f in clean) for i in range(len(st["grid"]))]
        pts, i = [], 0
        while i < len(counts):  # runs of equal counts: "from–to: count"
            j = i
            while j + 1 < len(counts) and counts[j + 1] == counts[i]:
                j += 1
            g = st["grid"]
            pts.append(("%.3g" % g[i] if i == j else "%.3g–%.3g" % (g[i], g[j])) + ": %d" % counts[i])
            i = j + 1
        out.append("* %s, clean %s with a false alarm (of %d) by %s: %s" % (
            label, "flights", len(clean), st["knob"], ", ".join(pts)))
    return out + ([""] if out else [])


def peer_label(key, settings):
    st = settings.get(key) or {}
    if st.get("label"):
        return st["label"]
    # peers.json from before several configurations (schema aerosid-peers/1): keys stlsq, frols
    if key.startswith("stlsq"):
        return "pysindy STLSQ"
    if key.startswith("frols"):
        return "sysidentpy FROLS" + (" (%s)" % st["info_criteria"].upper() if st.get("info_criteria") else "")
    return key


def describe(key, settings):
    st = settings.get(key) or {}
    if key.startswith("stlsq"):
        return "%s; ridge alpha %s, unbias %s; fitted on the identification rows" % (
            st.get("rule", "?"), st.get("alpha", "?"), st.get("unbias", "?"))
    if key.startswith("frols") and str(st.get("info_criteria", "")).startswith("err="):
        return "size: first k with cumulative ERR >= %s (sysidentpy err_tol), ERR forward selection, LeastSquares, " \
               "identification rows, no lags" % st["info_criteria"][4:]
    if key.startswith("frols"):
        return "size by %s (%s minimum), ERR forward selection, LeastSquares, identification rows, no lags" % (
            st.get("info_criteria", "?"), st.get("order", "global (schema 1)"))
    return json.dumps(st, ensure_ascii=False)


def fmt_frac(a, n):
    return "%d/%d" % (a, n) if n else "–"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("manifest")
    ap.add_argument("peers", nargs="*", help="peers files (default: peers.json next to the manifest)")
    ap.add_argument("-o", "--out")
    ap.add_argument("--truth", action="store_true",
                    help="also measure the flow-angle terms' reliability from the logs' true angles (slow)")
    a = ap.parse_args()
    base = os.path.dirname(os.path.abspath(a.manifest))
    flights = json.load(open(a.manifest))
    paths = a.peers or [os.path.join(base, "peers.json")]
    methods = [("aerosid gaps", lambda fl: fl.get("aerosid"))]
    notes, versions = [], {}
    sweeps = []  # (label, settings, {flight id: sweep record})
    for path in paths:
        if not os.path.exists(path):
            print("no peers file", path, file=sys.stderr)
            continue
        peers = json.load(open(path))
        versions.update(peers.get("versions", {}))
        for k, st in peers.get("sweeps", {}).items():
            recs = {f["id"]: f["sweeps"][k] for f in peers["flights"] if k in f.get("sweeps", {})}
            sweeps.append((st["label"], st, recs))
            notes.append("%s: %s; grid %.3g–%.3g (%d values)" % (st["label"], st["rule"], st["grid"][0], st["grid"][-1],
                                                               len(st["grid"])))
        by_id = {f["id"]: f["peers"] for f in peers["flights"]}
        keys = []
        for f in peers["flights"]:
            keys += [k for k in f["peers"] if k not in keys]
        settings = peers.get("settings", {})
        for k in keys:
            label = peer_label(k, settings)
            if len(paths) > 1 and any(m[0] == label for m in methods):
                label += " (%s)" % os.path.basename(path)
            methods.append((label, (lambda by_id, k: lambda fl: by_id.get(fl["id"], {}).get(k))(by_id, k)))
            notes.append("%s: %s" % (label, describe(k, settings)))
    lines = []
    suites = []
    for fl in flights:
        if fl.get("suite") not in suites:
            suites.append(fl.get("suite"))
    for suite in suites:
        fs = [f for f in flights if f.get("suite") == suite]
        scores = [(name, score_method(fs, g)) for name, g in methods]
        table = any(s["has_table"] for _, s in scores)
        lines.append("### suite `%s` (%d flights)\n" % (suite, len(fs)))
        head = ["method", "planted aero named", "planted sensor named", "clean flights with a cause", "named / clean flight", "named / flight"]
        if table:
            head += ["table effects named", "spurious / flight", "invented sensor errors"]
        head += ["median s / flight", "median CPU s / flight"]
        lines.append("| " + " | ".join(head) + " |")
        lines.append("|" + "---|" * len(head))
        for name, s in scores:
            if not s["named"]:
                row = [name] + ["no result"] * (len(head) - 1)
            else:
                row = [name, fmt_frac(s["aero_hit"], s["aero_n"]), fmt_frac(s["sens_hit"], s["sens_n"]),
                       fmt_frac(s["clean_named"], s["clean_n"]),
                       "%.1f" % statistics.mean(s["clean_items"]) if s["clean_items"] else "–",
                       "%.1f" % statistics.mean(s["named"])]
                if table:
                    row += [fmt_frac(s["table_named"], s["table_total"]),
                            "%.1f" % statistics.mean(s["spurious"]) if s["spurious"] else "–",
                            str(sum(s["invented"]))]
                row += ["%.3g" % statistics.median(s["secs"]) if s["secs"] else "–",
                        "%.3g" % statistics.median(s["cpu"]) if s["cpu"] else "–"]
            lines.append("| " + " | ".join(row) + " |")
        lines.append("")
        # Detection relative to the least detectable size: every suite whose planted effects
        # carry their size (the pooled cards and the single simulated and JSBSim flights).
        if any(f.get("pooled") is not None or any("size" in p for p in f.get("planted") or []) for f in fs):
            lines += pooled_section(suite, fs, methods, base)
        sw = [(label, st, recs, operating_point(fs, recs, st["grid"])) for label, st, recs in sweeps]
        lines += equal_fa_section(suite, fs, methods[0][1], sw, base)
        lines += sweep_curve(suite, fs, sw)
        lines += se_ratio_section(suite, fs, base)
        if suite != "real":
            # Real flights are of different aircraft: their scatter is not one term's error.
            lines += scatter_section(suite, fs, base)
        if a.truth:
            lines += reliability_section(suite, fs, base)
    lines.append("Versions: " + ", ".join("%s %s" % kv for kv in versions.items()))
    if notes:
        lines.append("")
        lines.append("Peer settings:")
        lines += ["* " + n for n in notes]
    out = "\n".join(lines) + "\n"
    try:
        print(out)
    except BrokenPipeError:
        pass
    if a.out:
        open(a.out, "w").write(out)


if __name__ == "__main__":
    main()
