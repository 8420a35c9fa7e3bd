#!/usr/bin/env python3
"""Run the peer methods - pysindy's STLSQ and sysidentpy's FROLS - on the regression tables of a
benchmark manifest and write which candidate terms each names (peers.json).

    target/venv/bin/python scripts/bench/peers.py MANIFEST.json [-o peers.json]
        [--stlsq cv,0.05,0.1,0.2] [--frols aic,bic,lilc,err=0.9999] [--frols-order first|global]

Several configurations per peer can be run in one pass; each is a key of "peers" in the output
(stlsq = validation rule, stlsq@0.1 = fixed threshold, frols = AIC, frols@bic, frols@err=0.9999)
with its settings and a label under "settings".

Contract (scripts/bench/README.md): the manifest is a list of flights
  {"id", "suite", "table" (CSV relative to the manifest), "split" (rows before it = identification),
   "planted", "coefficients": {coef: {"baseline": [terms], "candidates": {term: kind}}}, "aerosid"?}
and the table's header is  t_s, z:<coef>..., x:<term>...  (every term of every coefficient).

For every flight and coefficient the peers see the same columns: baseline + candidates.
  STLSQ  pysindy.optimizers.STLSQ on standardised columns (z-scored with the identification rows'
         mean and std, y too, intercept by centring), ridge alpha = pysindy's default 0.05,
         unbias = True, fitted on the identification rows. Threshold (in standardised coefficient
         units), --stlsq:
           cv     a fixed grid of 25 values, log-spaced 1e-3...1; for each, fit and score the MSE on
                  the validation rows; the LARGEST (sparsest) threshold within 1 % of the grid's
                  best MSE (in-sample MSE if there are no validation rows);
           NUMBER a fixed threshold, as pysindy's documentation uses it (default 0.1).
  FROLS  sysidentpy.model_structure_selection.FROLS used as a static regression: the library's
         information_criterion() over 1..n terms of its ERR forward orthogonal selection, then
         error_reduction_ratio() with the chosen size and LeastSquares - called on the given
         regressor matrix (no lags: max_lag = 0), because FROLS.fit() builds its own NARX
         polynomial basis from lagged inputs and cannot take arbitrary columns. Identification rows
         only (FROLS's order selection is in-sample). Size rule, --frols: an information criterion
         (aic, aicc, bic, fpe, lilc; as FROLS.fit, the FIRST local minimum of the criterion,
         get_min_info_value; --frols-order global for the global minimum), or err=TOL (stop when
         the cumulative ERR reaches TOL, sysidentpy's err_tol). One library information_criterion
         pass gives the residual variance per size; every criterion is evaluated on it with
         sysidentpy's own criterion functions.
Named terms = candidates (not baseline terms) with a nonzero coefficient in the final model.
"""
import argparse
import json
import os
import sys
import time
import warnings

# One BLAS thread per process: the matrices are small (thousands of rows, ~20 columns), and on a
# shared machine a multi-threaded BLAS spins and slows each fit several-fold; parallelism is over
# flights (--jobs).
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402


def load_table(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return header, data


def standardise(X, y, ident):
    mx = X[ident].mean(axis=0)
    sx = X[ident].std(axis=0)
    sx[sx == 0] = 1.0
    my = y[ident].mean()
    sy = y[ident].std() or 1.0
    return (X - mx) / sx, (y - my) / sy


THRESHOLDS = np.logspace(-3, 0, 25)


def stlsq_fit(Xs, ys, th):
    from pysindy.optimizers import STLSQ
    opt = STLSQ(threshold=float(th))  # alpha 0.05, unbias True, max_iter 20: pysindy defaults
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        opt.fit(Xs, ys.reshape(-1, 1))
    return np.asarray(opt.coef_).ravel()


def run_stlsq(X, y, n_ident, terms, threshold="cv"):
    """X without the constant column (centring replaces it), z-scored with the identification
    rows' statistics. threshold: a number (fixed, in standardised units, pysindy's default 0.1) or
    "cv" (grid + validation rule below). Fitted on the identification rows only.
    Returns (selected term names, threshold used)."""
    ident = slice(0, n_ident)
    valid = slice(n_ident, None)
    Xs, ys = standardise(X, y, ident)
    if threshold != "cv":
        coef = stlsq_fit(Xs[ident], ys[ident], float(threshold))
        return [terms[i] for i in np.flatnonzero(coef != 0)], float(threshold)
    has_valid = Xs[valid].shape[0] > 10
    results = []
    for th in THRESHOLDS:
        coef = stlsq_fit(Xs[ident], ys[ident], th)
        if has_valid:
            mse = float(np.mean((ys[valid] - Xs[valid] @ coef) ** 2))
        else:  # no validation rows: in-sample error (documented fallback)
            mse = float(np.mean((ys[ident] - Xs[ident] @ coef) ** 2))
        results.append((th, mse, coef))
    best = min(r[1] for r in results)
    chosen = max((r for r in results if r[1] <= 1.01 * best), key=lambda r: r[0])
    sel = [terms[i] for i in np.flatnonzero(chosen[2] != 0)]
    return sel, float(chosen[0])


def frols_inputs(X, y, n_ident):
    """(FROLS model as a static regression, max_lag = 0; the identification rows of X with columns
    scaled to unit RMS - ERR is scale-invariant, this only helps the conditioning; y's)."""
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares
    Xi = X[:n_ident]
    sc = np.sqrt(np.mean(Xi**2, axis=0))
    sc[sc == 0] = 1.0
    m = FROLS(order_selection=True, info_criteria="aic", n_info_values=max(Xi.shape[1], 1), estimator=LeastSquares(),
              ylag=1, xlag=1)
    m.max_lag = 0
    return m, Xi / sc, y[:n_ident].reshape(-1, 1)


def frols_prepare(X, y, n_ident):
    """The library's routines on the given matrix as a static regression (max_lag = 0).
    Returns (model, Xi, yi, e_var, err, piv): e_var[k-1] the residual variance of the size-k model.

    sysidentpy's information_criterion() refits the ERR selection once per size 1..n; the selection
    is greedy (size k's terms are the first k of any larger size's), so one error_reduction_ratio()
    pass over all n columns gives every size's terms, and each size's residual variance is computed
    exactly as information_criterion() does it (LeastSquares on those terms, np.var(ddof=1) of the
    residual) - equal to the library's to rounding, n times faster."""
    from sysidentpy.parameter_estimation import LeastSquares
    m, Xi, yi = frols_inputs(X, y, n_ident)
    n = Xi.shape[1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        err, piv, psi = m.error_reduction_ratio(Xi, yi, n)
        e_var = np.empty(n)
        for k in range(1, n + 1):
            theta = LeastSquares().optimize(psi[:, :k], yi)
            e_var[k - 1] = float(np.var(yi - psi[:, :k] @ theta, ddof=1))
    return m, Xi, yi, e_var, np.asarray(err, dtype=float), np.asarray(piv, dtype=int)


def run_frols(prep, terms, rule, order="first"):
    """rule: an information criterion of sysidentpy (aic, aicc, bic, fpe, lilc) or "err=TOL" (stop
    when the cumulative ERR reaches TOL - sysidentpy's err_tol semantics; computed from the full ERR
    sequence because 0.9.0's err_tol returns an unswapped column as the last term).
    order: "first" = the first local minimum of the criterion (sysidentpy's FROLS.fit,
    get_min_info_value), "global" = its global minimum."""
    from sysidentpy.model_structure_selection.ofr_base import get_info_criteria, get_min_info_value
    m, Xi, yi, e_var, err, piv = prep
    if rule.startswith("err="):
        n = err_size(err, float(rule[4:]))
    else:
        f = get_info_criteria(rule)
        N = Xi.shape[0]
        iv = np.array([f(k + 1, N, e_var[k]) for k in range(len(e_var))])
        n = int(get_min_info_value(iv)) if order == "first" else int(np.nanargmin(iv)) + 1
    return frols_terms(prep, terms, n), n


def err_size(err, tol):
    """sysidentpy's err_tol: the first size whose cumulative ERR reaches tol (all terms if none)."""
    hit = np.flatnonzero(np.cumsum(err) >= tol)
    return int(hit[0]) + 1 if hit.size else len(err)


def frols_terms(prep, terms, n):
    """The terms of the size-n FROLS model with a nonzero LeastSquares coefficient."""
    from sysidentpy.parameter_estimation import LeastSquares
    _, Xi, yi, _, _, piv = prep
    if n == 0:
        return []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        theta = LeastSquares().optimize(Xi[:, piv[:n]], yi).ravel()
    return [terms[int(piv[k])] for k in range(n) if theta[k] != 0]


def parse_configs(stlsq, frols, order):
    cfgs = []  # (key, peer, arg, settings)
    for v in stlsq.split(","):
        v = v.strip()
        if not v:
            continue
        if v == "cv":
            cfgs.append(("stlsq", "stlsq", "cv", {
                "peer": "stlsq", "threshold": "cv", "thresholds": [float(t) for t in THRESHOLDS], "alpha": 0.05,
                "unbias": True, "label": "pysindy STLSQ, threshold by validation (largest within 1 % of best MSE)",
                "rule": "largest threshold with validation MSE <= 1.01 x best, standardised columns"}))
        else:
            th = float(v)
            cfgs.append(("stlsq@%g" % th, "stlsq", th, {
                "peer": "stlsq", "threshold": th, "alpha": 0.05, "unbias": True,
                "label": "pysindy STLSQ, fixed threshold %g" % th,
                "rule": "fixed threshold %g on standardised columns" % th}))
    for v in frols.split(","):
        v = v.strip()
        if not v:
            continue
        rule, _, o = v.partition("/")  # "aic/global": this rule with the global minimum
        o = o or order
        if rule.startswith("err="):
            lab = "sysidentpy FROLS, cumulative ERR >= %s" % rule[4:]
            key = "frols@" + rule
        else:
            lab = "sysidentpy FROLS, %s (%s minimum)" % (rule.upper(), o)
            key = ("frols" if rule == "aic" else "frols@" + rule) + ("" if o == "first" else "/" + o)
        cfgs.append((key, "frols", (rule, o), {"peer": "frols", "info_criteria": rule, "order": o,
                                               "estimator": "LeastSquares", "rows": "identification",
                                               "lags": 0, "label": lab}))
    return cfgs


# The sweeps (--sweep): each peer's own selection knob over a grid, ordered from the most
# permissive value (names most) to the least; score.py picks, per suite, the most permissive value
# at which at most 1 clean flight in 10 has a candidate named (docs/benchmarks.md, "Peers at an
# equal false-alarm rate").
#   stlsq      STLSQ threshold on the z-scored columns, 8 per decade from 1e-3 to 10: above the
#              largest ridge coefficient of a coefficient's columns every term is cut, so the top
#              names nothing on any coefficient whose z-scored coefficients stay below 10.
#   frols-pen  FROLS with the baseline forced in (the model the peers are told, as aerosid is): the
#              library's ERR forward selection orders the candidates after the baseline, and the
#              number k >= 0 of candidates is the global minimum of N ln(e_var(k)) + c k (AIC: c = 2,
#              BIC: c = ln N), c 8 per decade from 1 to 1e5: k is non-increasing in c, and a c high
#              enough keeps the baseline alone.
#   frols-err  FROLS as sysidentpy runs it (no term forced), size by its err_tol (the first size
#              whose cumulative ERR reaches tol), 1 - tol 4 per decade from 1e-12 to 1: the size is
#              non-increasing as tol falls; its least permissive end is the one-term model, which
#              can be a candidate (the library's own knob cannot go below one term).
SWEEPS = {
    "stlsq": dict(peer="stlsq", knob="threshold", grid=[float(v) for v in np.logspace(-3, 1, 33)],
                  label="pysindy STLSQ, threshold swept",
                  rule="STLSQ (ridge alpha 0.05, unbias) at each threshold on the z-scored columns"),
    "frols-pen": dict(peer="frols", knob="penalty per candidate term", grid=[float(v) for v in np.logspace(0, 5, 41)],
                      label="sysidentpy FROLS, baseline forced, penalty swept",
                      rule="baseline forced; candidates in ERR order; k = global minimum over k >= 0 of "
                           "N ln e_var(k) + c k (AIC c = 2, BIC c = ln N)"),
    "frols-err": dict(peer="frols", knob="1 - err_tol", grid=[float(v) for v in np.logspace(-12, 0, 49)],
                      label="sysidentpy FROLS, ERR tolerance swept",
                      rule="size = first k whose cumulative ERR reaches tol (sysidentpy's err_tol)"),
}
RIDGE_ALPHA = 0.05  # pysindy's STLSQ default


def frols_forced(X, y, n_ident, nb):
    """FROLS's ERR forward selection over the candidates with the first nb columns (the baseline)
    forced in: the library's error_reduction_ratio() on the candidate columns and the coefficient
    with the baseline projected out (the ERR order after a forced block is the order on those
    residuals: every later step orthogonalises against the block anyway). Returns (order of the
    candidate columns as indices of X, e_var[k] of baseline + the first k candidates, k = 0..n),
    e_var as the library's information_criterion() computes it (LeastSquares, np.var ddof=1)."""
    from sysidentpy.parameter_estimation import LeastSquares
    m, Xi, yi = frols_inputs(X, y, n_ident)
    B, C = Xi[:, :nb], Xi[:, nb:]
    if nb:
        P = np.linalg.lstsq(B, np.hstack([C, yi]), rcond=None)[0]
        R = np.hstack([C, yi]) - B @ P
    else:
        R = np.hstack([C, yi])
    n = C.shape[1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if n:
            _, piv, _ = m.error_reduction_ratio(R[:, :n], R[:, n:], n)
        else:
            piv = np.zeros(0, dtype=int)
        order = [nb + int(j) for j in piv]
        e_var = np.empty(n + 1)
        for k in range(n + 1):
            cols = list(range(nb)) + order[:k]
            theta = LeastSquares().optimize(Xi[:, cols], yi) if cols else np.zeros((0, 1))
            e_var[k] = float(np.var(yi - Xi[:, cols] @ theta, ddof=1))
    return order, e_var


def stlsq_path(Xs, ys, grid):
    """STLSQ coefficients at every threshold of grid (ascending) on the identification rows.

    Two shortcuts, both exact: above the largest |coefficient| of the initial ridge fit (STLSQ's
    first step, the same ridge pysindy solves) every term is cut, so no fit is made there; and once a
    threshold keeps every term, every smaller one does too (STLSQ only removes terms below the
    threshold), so the smaller ones reuse that fit. Between the two the library fits each one."""
    n = Xs.shape[1]
    w = np.linalg.solve(Xs.T @ Xs + RIDGE_ALPHA * np.eye(n), Xs.T @ ys)
    top = float(np.max(np.abs(w))) if n else 0.0
    out = [None] * len(grid)
    for i in reversed(range(len(grid))):
        if grid[i] > 1.001 * top:
            out[i] = np.zeros(n)
            continue
        c = stlsq_fit(Xs, ys, grid[i])
        out[i] = c
        if np.all(c != 0):
            for j in range(i):
                out[j] = c
            break
    return out


def sweep_named(key, X, y, n_id, terms, nc, nb, prep):
    """[selected terms at each grid value] of one sweep on one coefficient."""
    grid = SWEEPS[key]["grid"]
    if key == "stlsq":
        Xs, ys = standardise(X[:, nc], y, slice(0, n_id))
        names = [terms[i] for i in nc]
        return [[names[j] for j in np.flatnonzero(c != 0)] for c in stlsq_path(Xs[:n_id], ys[:n_id], grid)]
    if key == "frols-pen":
        order, e_var = frols_forced(X, y, n_id, nb)
        with np.errstate(divide="ignore"):
            crit = n_id * np.log(e_var)
        ks = np.arange(len(e_var))
        return [[terms[j] for j in order[:int(np.argmin(crit + c * ks))]] for c in grid]
    err = prep[4]
    cache = {}
    return [cache.setdefault(k, frols_terms(prep, terms, k)) for k in (err_size(err, 1.0 - g) for g in grid)]


def run_flight(job):
    """Every configuration and sweep on one flight of the manifest -> its peers.json record."""
    fl, base, cfgs, sweeps = job
    header, data = load_table(os.path.join(base, fl["table"]))
    col = {h: i for i, h in enumerate(header)}
    n_ident = int(fl["split"])
    rec = {"id": fl["id"], "suite": fl.get("suite"), "peers": {}}
    details = {k: {} for k, *_ in cfgs}
    named = {k: [] for k, *_ in cfgs}
    secs = {k: 0.0 for k, *_ in cfgs}
    cpu = {k: 0.0 for k, *_ in cfgs}
    sw = {k: {"items": [], "path": [[] for _ in SWEEPS[k]["grid"]], "seconds": 0.0, "cpu_seconds": 0.0}
          for k in sweeps}
    for coef, spec in fl["coefficients"].items():
        zname = "z:" + coef
        if zname not in col:
            continue
        cands = spec.get("candidates", {})
        base_terms = list(spec["baseline"])
        terms = [t for t in base_terms + [c for c in cands if c not in base_terms] if "x:" + t in col]
        y = data[:, col[zname]]
        X = np.column_stack([data[:, col["x:" + t]] for t in terms])
        ok = np.isfinite(y) & np.all(np.isfinite(X), axis=1)
        if not ok.all():  # rows with NaN are dropped; the split counts original rows
            n_id = int(ok[:n_ident].sum())
            X, y = X[ok], y[ok]
        else:
            n_id = n_ident
        # STLSQ: the constant column is replaced by centring; columns constant on the
        # identification rows are left out.
        nc = [i for i, t in enumerate(terms) if np.ptp(X[:n_id, i]) > 0]
        prep, prep_secs, prep_cpu = None, 0.0, 0.0

        def frols_prep():
            nonlocal prep, prep_secs, prep_cpu
            if prep is None:  # one ERR pass shared by every FROLS rule and sweep
                t0, c0 = time.perf_counter(), time.process_time()
                prep = frols_prepare(X, y, n_id)
                prep_secs, prep_cpu = time.perf_counter() - t0, time.process_time() - c0
            return prep

        def is_named(t):  # a baseline term is never named, even if also listed as a candidate
            return t in cands and t not in base_terms

        for key, peer, arg, _ in cfgs:
            if peer == "frols":
                frols_prep()
                secs[key] += prep_secs
                cpu[key] += prep_cpu
            t0, c0 = time.perf_counter(), time.process_time()
            if peer == "stlsq":
                sel, th = run_stlsq(X[:, nc], y, n_id, [terms[i] for i in nc], arg)
                details[key][coef] = {"selected": sel, "threshold": th}
            else:
                sel, n = run_frols(prep, terms, arg[0], arg[1])
                details[key][coef] = {"selected": sel, "n_terms": n}
            secs[key] += time.perf_counter() - t0
            cpu[key] += time.process_time() - c0
            named[key] += [{"location": coef, "term": t, "kind": cands[t]} for t in sel if is_named(t)]
        for key in sweeps:
            r = sw[key]
            if key == "frols-err":
                frols_prep()
                r["seconds"] += prep_secs
                r["cpu_seconds"] += prep_cpu
            t0, c0 = time.perf_counter(), time.process_time()
            path = sweep_named(key, X, y, n_id, terms, nc, sum(t in base_terms for t in terms), prep)
            r["seconds"] += time.perf_counter() - t0
            r["cpu_seconds"] += time.process_time() - c0
            for i, sel in enumerate(path):
                for t in sel:
                    if not is_named(t):
                        continue
                    item = [coef, t, cands[t]]
                    if item not in r["items"]:
                        r["items"].append(item)
                    r["path"][i].append(r["items"].index(item))
    for key, *_ in cfgs:
        rec["peers"][key] = {"named": named[key], "seconds": round(secs[key], 4),
                             "cpu_seconds": round(cpu[key], 4), "fits": details[key]}
    if sweeps:
        for r in sw.values():
            r["seconds"] = round(r["seconds"], 4)
            r["cpu_seconds"] = round(r["cpu_seconds"], 4)
        rec["sweeps"] = sw
    return rec


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("manifest")
    ap.add_argument("-o", "--out", default=None, help="default: peers.json next to the manifest")
    ap.add_argument("--stlsq", default=None,
                    help="comma list of STLSQ thresholds: cv (validation rule, default without --sweep) and/or numbers, "
                         "e.g. cv,0.05,0.1,0.2")
    ap.add_argument("--frols", "--frols-ic", dest="frols", default=None,
                    help="comma list of FROLS size rules: aic (default without --sweep), aicc, bic, fpe, lilc, err=TOL "
                         "(cumulative ERR); RULE/global for the criterion's global minimum")
    ap.add_argument("--frols-order", default="first", choices=["first", "global"],
                    help="criterion minimum: first local (sysidentpy's fit, default) or global")
    ap.add_argument("--sweep", default=None,
                    help="comma list of knob sweeps: stlsq, frols-pen, frols-err, or all (for the comparison at an equal "
                         "false-alarm rate, score.py)")
    ap.add_argument("--jobs", type=int, default=1, help="flights analysed in parallel processes (default 1)")
    a = ap.parse_args()
    import pysindy
    import sysidentpy
    sweeps = [] if not a.sweep else (list(SWEEPS) if a.sweep == "all" else [s.strip() for s in a.sweep.split(",")])
    for k in sweeps:
        if k not in SWEEPS:
            ap.error("--sweep: unknown sweep %r (known: %s, all)" % (k, ", ".join(SWEEPS)))
    default = "" if sweeps else None
    cfgs = parse_configs(a.stlsq if a.stlsq is not None else (default if default is not None else "cv"),
                         a.frols if a.frols is not None else (default if default is not None else "aic"),
                         a.frols_order)
    base = os.path.dirname(os.path.abspath(a.manifest))
    flights = json.load(open(a.manifest))
    out = {"schema": "aerosid-peers/3",
           "versions": {"python": sys.version.split()[0], "numpy": np.__version__,
                        "pysindy": pysindy.__version__, "sysidentpy": sysidentpy.__version__},
           "settings": {k: st for k, _, _, st in cfgs},
           "sweeps": {k: SWEEPS[k] for k in sweeps},
           "flights": []}
    jobs = [(fl, base, cfgs, sweeps) for fl in flights]
    if a.jobs > 1:
        import multiprocessing
        pool = multiprocessing.Pool(a.jobs)
        results = pool.imap(run_flight, jobs)
    else:
        pool, results = None, map(run_flight, jobs)
    for rec in results:
        out["flights"].append(rec)
        print("%-34s " % rec["id"] + "  ".join("%s %d" % (k, len(v["named"])) for k, v in rec["peers"].items())
              + "".join("  %s %.1f s" % (k, v["cpu_seconds"]) for k, v in rec.get("sweeps", {}).items()), flush=True)
    if pool is not None:
        pool.close()
        pool.join()
    path = a.out or os.path.join(base, "peers.json")
    json.dump(out, open(path, "w"), indent=1, ensure_ascii=False)
    print("wrote", path)


if __name__ == "__main__":
    main()
