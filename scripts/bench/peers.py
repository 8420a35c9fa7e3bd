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

import numpy as np


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


def frols_prepare(X, y, n_ident):
    """The library's routines on the given matrix as a static regression (max_lag = 0).
    Returns (model, Xi, yi, per-size residual variance from FROLS.information_criterion)."""
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares
    Xi = X[:n_ident]
    yi = y[:n_ident].reshape(-1, 1)
    # Scale columns to unit RMS (ERR is scale-invariant; this only helps the conditioning).
    sc = np.sqrt(np.mean(Xi**2, axis=0))
    sc[sc == 0] = 1.0
    Xi = Xi / sc
    m = FROLS(order_selection=True, info_criteria="aic", n_info_values=Xi.shape[1], estimator=LeastSquares(),
              ylag=1, xlag=1)
    m.max_lag = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        iv = np.asarray(m.information_criterion(Xi, yi), dtype=float)
    # aic = N ln(e_var) + 2 n  ->  e_var per size, so every criterion comes from one library pass
    N = Xi.shape[0]
    sizes = np.arange(1, len(iv) + 1)
    e_var = np.exp((iv - 2 * sizes) / N)
    return m, Xi, yi, e_var


def run_frols(prep, terms, rule, order="first"):
    """rule: an information criterion of sysidentpy (aic, aicc, bic, fpe, lilc) or "err=TOL" (stop
    when the cumulative ERR reaches TOL - sysidentpy's err_tol semantics; computed from the full ERR
    sequence because 0.9.0's err_tol returns an unswapped column as the last term).
    order: "first" = the first local minimum of the criterion (sysidentpy's FROLS.fit,
    get_min_info_value), "global" = its global minimum."""
    from sysidentpy.model_structure_selection.ofr_base import get_info_criteria, get_min_info_value
    from sysidentpy.parameter_estimation import LeastSquares
    m, Xi, yi, e_var = prep
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if rule.startswith("err="):
            tol = float(rule[4:])
            err, piv, _ = m.error_reduction_ratio(Xi, yi, Xi.shape[1])
            cum = np.cumsum(np.asarray(err, dtype=float))
            hit = np.flatnonzero(cum >= tol)
            n = int(hit[0]) + 1 if hit.size else Xi.shape[1]
        else:
            f = get_info_criteria(rule)
            N = Xi.shape[0]
            iv = np.array([f(k + 1, N, e_var[k]) for k in range(len(e_var))])
            n = int(get_min_info_value(iv)) if order == "first" else int(np.nanargmin(iv)) + 1
        err, piv, psi = m.error_reduction_ratio(Xi, yi, n)
        theta = LeastSquares().optimize(psi, yi).ravel()
    sel = [terms[int(piv[k])] for k in range(n) if theta[k] != 0]
    return sel, n


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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("manifest")
    ap.add_argument("-o", "--out", default=None, help="default: peers.json next to the manifest")
    ap.add_argument("--stlsq", default="cv",
                    help="comma list of STLSQ thresholds: cv (validation rule, default) and/or numbers, e.g. cv,0.05,0.1,0.2")
    ap.add_argument("--frols", "--frols-ic", dest="frols", default="aic",
                    help="comma list of FROLS size rules: aic (default), aicc, bic, fpe, lilc, err=TOL (cumulative ERR); "
                         "RULE/global for the criterion's global minimum")
    ap.add_argument("--frols-order", default="first", choices=["first", "global"],
                    help="criterion minimum: first local (sysidentpy's fit, default) or global")
    a = ap.parse_args()
    import pysindy
    import sysidentpy
    cfgs = parse_configs(a.stlsq, a.frols, a.frols_order)
    base = os.path.dirname(os.path.abspath(a.manifest))
    flights = json.load(open(a.manifest))
    out = {"schema": "aerosid-peers/2",
           "versions": {"python": sys.version.split()[0], "numpy": np.__version__,
                        "pysindy": pysindy.__version__, "sysidentpy": sysidentpy.__version__},
           "settings": {k: st for k, _, _, st in cfgs},
           "flights": []}
    for fl in flights:
        header, data = load_table(os.path.join(base, fl["table"]))
        col = {h: i for i, h in enumerate(header)}
        n_ident = int(fl["split"])
        rec = {"id": fl["id"], "suite": fl.get("suite"), "peers": {}}
        details = {k: {} for k, *_ in cfgs}
        named = {k: [] for k, *_ in cfgs}
        secs = {k: 0.0 for k, *_ in cfgs}
        cpu = {k: 0.0 for k, *_ in cfgs}
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
            for key, peer, arg, _ in cfgs:
                t0, c0 = time.perf_counter(), time.process_time()
                if peer == "stlsq":
                    sel, th = run_stlsq(X[:, nc], y, n_id, [terms[i] for i in nc], arg)
                    details[key][coef] = {"selected": sel, "threshold": th}
                else:
                    if prep is None:  # one information_criterion pass shared by the FROLS rules
                        prep = frols_prepare(X, y, n_id)
                        prep_secs, prep_cpu = time.perf_counter() - t0, time.process_time() - c0
                        t0, c0 = time.perf_counter(), time.process_time()
                    sel, n = run_frols(prep, terms, arg[0], arg[1])
                    details[key][coef] = {"selected": sel, "n_terms": n}
                    secs[key] += prep_secs
                    cpu[key] += prep_cpu
                secs[key] += time.perf_counter() - t0
                cpu[key] += time.process_time() - c0
                # named = candidates only (a baseline term is never named, even if also listed as a candidate)
                named[key] += [{"location": coef, "term": t, "kind": cands[t]} for t in sel
                               if t in cands and t not in base_terms]
        for key, *_ in cfgs:
            rec["peers"][key] = {"named": named[key], "seconds": round(secs[key], 4),
                                 "cpu_seconds": round(cpu[key], 4), "fits": details[key]}
        out["flights"].append(rec)
        print("%-34s " % fl["id"] + "  ".join("%s %d" % (k, len(named[k])) for k, *_ in cfgs), flush=True)
    path = a.out or os.path.join(base, "peers.json")
    json.dump(out, open(path, "w"), indent=1, ensure_ascii=False)
    print("wrote", path)


if __name__ == "__main__":
    main()
