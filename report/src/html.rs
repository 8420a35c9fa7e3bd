//! `report.html`: the model-gap report as one self-contained page a flight-test engineer reads at a
//! glance (docs/reports.md).
//!
//! The page is built from the report's JSON value (what `report.json` holds) and the SVG figures
//! written beside it, not from the analysis' types: the analysis can change its internals, and a
//! field the page looks for that is missing is left out of the page rather than failing it. Every
//! text from the report is HTML-escaped; the figures are embedded as SVG text (their XML prologue
//! removed). The page loads nothing: no scripts, no fonts, no external style sheets.
//!
//! Written with `std::fmt::Write` rather than a template crate (`maud`, `askama`): the page is a
//! handful of tables walked from a `serde_json::Value` whose shape is only known at run time, which
//! a compile-time template checks no better than this code, and a template crate would add a
//! proc-macro dependency to the tool's build for about 200 lines of markup.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde_json::Value;

/// Why a page could not be written.
#[derive(Debug)]
pub enum HtmlError {
    /// A file could not be read or written.
    Io(PathBuf, std::io::Error),
    /// The report file is not JSON.
    Json(PathBuf, String),
}

impl std::fmt::Display for HtmlError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Io(p, e) => write!(f, "{}: {e}", p.display()),
            Self::Json(p, e) => write!(f, "{}: not a JSON report: {e}", p.display()),
        }
    }
}

impl std::error::Error for HtmlError {}

/// The style sheet of every page: readable without it, a little tidier with it.
const STYLE: &str = "body{font-family:sans-serif;max-width:1000px;margin:1em auto;padding:0 1em;color:#222;line-height:1.4}\
h1{font-size:1.5em;margin-bottom:.2em}h2{font-size:1.2em;border-bottom:1px solid #ccc;margin-top:1.6em}\
.meta{color:#555;margin-top:0}\
.verdict{padding:.8em 1em;border-radius:6px;font-size:1.1em;border:2px solid}\
.found{background:#e6f4ea;border-color:#1e7e34}.clean{background:#eef3fb;border-color:#0072b2}\
.none{background:#fff4e0;border-color:#b26b00}\
table{border-collapse:collapse;margin:.5em 0}th,td{border:1px solid #ccc;padding:.25em .6em;text-align:left;vertical-align:top}\
th{background:#f2f2f2}td.num,td.terms{white-space:nowrap}td.num{text-align:right;font-variant-numeric:tabular-nums}\
.yes{color:#1e7e34;font-weight:bold}.no{color:#b00020;font-weight:bold}\
figure{margin:1em 0}figure svg{width:100%;height:auto;border:1px solid #ddd}figcaption{color:#555}\
ul{padding-left:1.4em}";

/// Writes `report.html` for the gap report `json_path` (the `report.json` just written) with the
/// SVG figures among `files` embedded; returns the page's path (beside the JSON file).
///
/// # Errors
/// [`HtmlError`] naming the file that could not be read, parsed or written.
pub fn write_gaps(json_path: &Path, files: &[PathBuf]) -> Result<PathBuf, HtmlError> {
    let text = std::fs::read_to_string(json_path).map_err(|e| HtmlError::Io(json_path.to_path_buf(), e))?;
    let report: Value =
        serde_json::from_str(&text).map_err(|e| HtmlError::Json(json_path.to_path_buf(), e.to_string()))?;
    let mut figures = Vec::new();
    for p in files.iter().filter(|p| p.extension().is_some_and(|e| e == "svg")) {
        let svg = std::fs::read_to_string(p).map_err(|e| HtmlError::Io(p.clone(), e))?;
        let name = p
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        figures.push((name, svg));
    }
    let page = json_path.with_file_name("report.html");
    std::fs::write(&page, gaps_page(&report, &figures)).map_err(|e| HtmlError::Io(page.clone(), e))?;
    Ok(page)
}

/// The page of a gap report: its JSON value and the figures as (file name, SVG text).
pub fn gaps_page(r: &Value, figures: &[(String, String)]) -> String {
    let mut h = String::new();
    let source = text(r, &["source"]).unwrap_or_default();
    head(&mut h, &format!("model-gap report — {source}"));
    let _ = write!(
        h,
        "<h1>Model-gap report</h1><p class=\"meta\">flight <b>{}</b>",
        esc(&source)
    );
    if let Some(a) = text(r, &["aircraft"]) {
        let _ = write!(h, " · aircraft {}", esc(&a));
    }
    if let (Some(i), Some(v)) = (
        r.pointer("/segments/identification_s"),
        r.pointer("/segments/validation_s"),
    ) {
        let _ = write!(h, " · identification {} · held out {}", span_s(i), span_s(v));
    }
    h.push_str("</p>");
    verdict(&mut h, r);
    data_quality(&mut h, r);
    named(&mut h, r);
    coefficients(&mut h, r);
    compatibility(&mut h, r);
    simulation(&mut h, r);
    list_section(&mut h, "Notes", r.get("notes"));
    criterion(&mut h, r);
    figures_section(&mut h, figures);
    h.push_str("</body></html>\n");
    h
}

fn head(h: &mut String, title: &str) {
    let _ = write!(
        h,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>{}</title>\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><style>{STYLE}</style></head><body>",
        esc(title)
    );
}

/// The overall verdict in a coloured box: green when a cause is named, blue when nothing is missing,
/// amber when there is no verdict.
fn verdict(h: &mut String, r: &Value) {
    let v = text(r, &["verdict"]).unwrap_or_else(|| "no verdict recorded in the report".into());
    let named = r.get("named").and_then(Value::as_array).is_some_and(|a| !a.is_empty());
    let no_verdict = v.starts_with("no verdict")
        || r.get("status").and_then(Value::as_str) == Some("no_verdict")
        || r.pointer("/data_quality/supports_verdict") == Some(&Value::Bool(false))
        || r.get("no_verdict")
            .is_some_and(|x| !x.is_null() && x != &Value::Bool(false));
    let class = if no_verdict {
        "none"
    } else if named {
        "found"
    } else {
        "clean"
    };
    let _ = write!(
        h,
        "<div class=\"verdict {class}\" id=\"verdict\"><b>Verdict:</b> {}",
        esc(&v)
    );
    if let Some(t) = r.get("top_cause").filter(|t| t.is_object()) {
        let what = [text(t, &["what"]), text(t, &["location"])]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>()
            .join(" in ");
        if !what.is_empty() {
            let _ = write!(h, "<br><b>Top cause:</b> {}", esc(&what));
        }
    }
    // The machine-readable reasons (`reasons`, beside `status`) where the report has them.
    let reasons = r
        .get("reasons")
        .filter(|x| x.as_array().is_some_and(|a| !a.is_empty()))
        .or_else(|| r.pointer("/data_quality/why_not"));
    if let Some(reasons) = reasons.and_then(Value::as_array) {
        let reasons: Vec<String> = reasons.iter().filter_map(Value::as_str).map(esc).collect();
        if !reasons.is_empty() && !reasons.iter().all(|x| v.contains(x.as_str())) {
            let _ = write!(h, "<ul><li>{}</li></ul>", reasons.join("</li><li>"));
        }
    }
    h.push_str("</div>");
}

fn data_quality(h: &mut String, r: &Value) {
    let Some(q) = r.get("data_quality").filter(|q| q.is_object()) else {
        return;
    };
    h.push_str("<h2 id=\"data-quality\">Data quality</h2><p>");
    let mut facts = Vec::new();
    if let Some(n) = q.get("samples").and_then(Value::as_u64) {
        facts.push(format!("{n} samples"));
    }
    if let Some(d) = num(q, "duration_s") {
        facts.push(format!("{d:.1} s"));
    }
    if let Some(f) = num(q, "rate_hz") {
        facts.push(format!("{f:.1} Hz"));
    }
    if let Some(f) = text(q, &["format"]).filter(|f| !f.is_empty()) {
        facts.push(f);
    }
    h.push_str(&esc(&facts.join(" · ")));
    if let Some(a) = text(q, &["air_data"]) {
        let _ = write!(h, "<br>air data: {}", esc(&a));
    }
    if let Some(s) = text(q, &["flow_angles", "summary"]) {
        let _ = write!(h, "<br>flow angles: {}", esc(&s));
    }
    match q.get("supports_verdict").and_then(Value::as_bool) {
        Some(true) => h.push_str("<br><span class=\"yes\">these data support a verdict</span>"),
        Some(false) => h.push_str("<br><span class=\"no\">these data cannot support a verdict</span>"),
        None => {}
    }
    h.push_str("</p>");
    // The reasons for no verdict are listed once, in the verdict's box (`verdict`).
    list(h, q.get("warnings"), "warnings");
    if let Some(cs) = q
        .get("coefficients")
        .and_then(Value::as_array)
        .filter(|c| !c.is_empty())
    {
        h.push_str("<table><tr><th>coefficient</th><th>identifiable from what is logged</th><th>why not</th></tr>");
        for c in cs {
            let ok = c.get("identifiable").and_then(Value::as_bool);
            let _ = write!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td></tr>",
                esc(&text(c, &["coefficient"]).unwrap_or_default()),
                match ok {
                    Some(true) => "<span class=\"yes\">yes</span>",
                    Some(false) => "<span class=\"no\">no</span>",
                    None => "",
                },
                strings(c.get("notes"))
                    .iter()
                    .map(|s| esc(s))
                    .collect::<Vec<_>>()
                    .join("<br>")
            );
        }
        h.push_str("</table>");
    }
}

fn named(h: &mut String, r: &Value) {
    let Some(named) = r.get("named").and_then(Value::as_array) else {
        return;
    };
    h.push_str("<h2 id=\"causes\">Named causes</h2>");
    if named.is_empty() {
        h.push_str("<p>None: no candidate predicts held-out data better than the baseline beyond noise.</p>");
        return;
    }
    h.push_str("<table><tr><th>cause</th><th>where</th><th>kind</th><th>estimate ± σ</th><th>t²</th></tr>");
    for c in named {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
            esc(&text(c, &["what"]).unwrap_or_default()),
            esc(&text(c, &["location"]).unwrap_or_default()),
            esc(&text(c, &["kind"]).unwrap_or_default()),
            value_sigma(c.get("value"), c.get("sigma"), None),
            opt(num(c, "t2"), 1)
        );
    }
    h.push_str("</table>");
}

/// The per-coefficient table: held-out R² before → after, each added term ± σ, the verdict.
fn coefficients(h: &mut String, r: &Value) {
    let Some(cs) = r
        .get("coefficients")
        .and_then(Value::as_array)
        .filter(|c| !c.is_empty())
    else {
        return;
    };
    h.push_str(
        "<h2 id=\"coefficients\">Coefficients</h2><table><tr><th>coefficient</th><th>held-out R² baseline</th>\
         <th>held-out R² extended</th><th>added terms (estimate ± σ)</th><th>verdict</th></tr>",
    );
    for c in cs {
        let before = num(c, "cv_r2_baseline").or_else(|| c.pointer("/baseline/validation/r2").and_then(Value::as_f64));
        let after = num(c, "cv_r2_extended").or_else(|| c.pointer("/extended/validation/r2").and_then(Value::as_f64));
        let added = c.get("added").and_then(Value::as_array).map_or_else(Vec::new, |a| {
            a.iter()
                .map(|t| {
                    format!(
                        "{} = {}",
                        esc(&text(t, &["term"]).unwrap_or_default()),
                        value_sigma(t.get("value"), t.get("sigma"), None)
                    )
                })
                .collect()
        });
        let _ = write!(
            h,
            "<tr><td><b>{}</b></td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"terms\">{}</td><td>{}</td></tr>",
            esc(&text(c, &["name"]).unwrap_or_default()),
            opt(before, 4),
            opt(after, 4),
            if added.is_empty() {
                "nothing".into()
            } else {
                added.join("<br>")
            },
            esc(&text(c, &["verdict"]).unwrap_or_default())
        );
    }
    h.push_str("</table>");
}

/// The flight-path reconstruction: output RMS before and after, sensor errors found and rejected.
fn compatibility(h: &mut String, r: &Value) {
    let Some(c) = r.get("compatibility").filter(|c| c.is_object()) else {
        return;
    };
    h.push_str("<h2 id=\"compatibility\">Sensor compatibility (flight-path reconstruction)</h2>");
    if let Some(os) = c.get("outputs").and_then(Value::as_array).filter(|o| !o.is_empty()) {
        h.push_str("<table><tr><th>output</th><th>RMS before</th><th>RMS after</th></tr>");
        for o in os {
            let _ = write!(
                h,
                "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
                esc(&text(o, &["channel"]).unwrap_or_default()),
                opt_sig(num(o, "rms_before")),
                opt_sig(num(o, "rms_after"))
            );
        }
        h.push_str("</table>");
    }
    for (key, title) in [("found", "Sensor errors found"), ("rejected", "Not named")] {
        let Some(fs) = c.get(key).and_then(Value::as_array) else {
            continue;
        };
        let _ = write!(h, "<h3>{title}</h3>");
        if fs.is_empty() {
            h.push_str("<p>none</p>");
            continue;
        }
        h.push_str("<table><tr><th>parameter</th><th>estimate ± σ</th><th>t²</th><th>held-out gain [σ]</th>");
        if key == "rejected" {
            h.push_str("<th>why not</th>");
        }
        h.push_str("</tr>");
        for f in fs {
            let unit = text(f, &["unit"]);
            let _ = write!(
                h,
                "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>",
                esc(&text(f, &["parameter"]).unwrap_or_default()),
                value_sigma(f.get("value"), f.get("sigma"), unit.as_deref()),
                opt(num(f, "t2"), 1),
                opt(num(f, "cv_gain_z"), 1)
            );
            if key == "rejected" {
                let _ = write!(h, "<td>{}</td>", esc(&text(f, &["why"]).unwrap_or_default()));
            }
            h.push_str("</tr>");
        }
        h.push_str("</table>");
    }
}

/// The held-out segment simulated with both models.
fn simulation(h: &mut String, r: &Value) {
    let Some(os) = r
        .pointer("/simulation/outputs")
        .and_then(Value::as_array)
        .filter(|o| !o.is_empty())
    else {
        return;
    };
    h.push_str(
        "<h2 id=\"simulation\">Held-out simulation</h2><table><tr><th>output</th><th>R² baseline</th>\
         <th>R² extended</th><th>RMS baseline</th><th>RMS extended</th></tr>",
    );
    // A model set whose simulation diverged has no R² or RMS (null): the cell says "diverged" and
    // a line below says where.
    let mut diverged = Vec::new();
    for o in os {
        let unit = text(o, &["unit"]).map(|u| format!(" {}", esc(&u))).unwrap_or_default();
        let channel = esc(&text(o, &["channel"]).unwrap_or_default());
        let cut = |w: usize| -> Option<String> {
            let at: Vec<String> = o
                .pointer(&format!("/diverged_at_s/{w}"))
                .and_then(Value::as_array)?
                .iter()
                .filter_map(Value::as_f64)
                .map(|t| format!("{t:.1}"))
                .collect();
            (!at.is_empty()).then(|| at.join(", "))
        };
        let cell = |w: usize, m: &str, r2: bool| match cut(w) {
            Some(_) => "diverged".to_string(),
            None if r2 => opt(o.pointer(&format!("/{m}/r2")).and_then(Value::as_f64), 3),
            None => format!(
                "{}{unit}",
                opt_sig(o.pointer(&format!("/{m}/rms")).and_then(Value::as_f64))
            ),
        };
        for (w, m) in [(0, "baseline"), (1, "extended")] {
            if let Some(at) = cut(w) {
                diverged.push(format!("{channel} with the {m} models diverged at t = {at} s"));
            }
        }
        let _ = write!(
            h,
            "<tr><td>{channel}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
            cell(0, "baseline", true),
            cell(1, "extended", true),
            cell(0, "baseline", false),
            cell(1, "extended", false),
        );
    }
    h.push_str("</table>");
    if !diverged.is_empty() {
        let _ = write!(h, "<ul><li>{}</li></ul>", diverged.join("</li><li>"));
    }
    list(h, r.pointer("/simulation/notes"), "");
}

/// How the causes were tested, in one line.
fn criterion(h: &mut String, r: &Value) {
    let Some(c) = r.get("criterion").filter(|c| c.is_object()) else {
        return;
    };
    let mut parts = Vec::new();
    if let Some(s) = text(c, &["statistic"]) {
        parts.push(s);
    }
    if let Some(n) = c.get("candidates_tested").and_then(Value::as_u64) {
        parts.push(format!("{n} candidates tested"));
    }
    if let Some(a) = num(c, "alpha") {
        parts.push(format!("family-wise level α = {a}"));
    }
    if let Some(a) = num(c, "gain_alpha") {
        parts.push(format!("held-out gain level {a}"));
    }
    if parts.is_empty() {
        return;
    }
    let _ = write!(
        h,
        "<h2 id=\"criterion\">Criterion</h2><p>{}</p>",
        esc(&parts.join("; "))
    );
}

fn figures_section(h: &mut String, figures: &[(String, String)]) {
    if figures.is_empty() {
        return;
    }
    h.push_str("<h2 id=\"figures\">Figures</h2>");
    for (name, svg) in figures {
        let _ = write!(
            h,
            "<figure>{}<figcaption>{}</figcaption></figure>",
            inline_svg(svg),
            esc(name)
        );
    }
}

/// An SVG document as an element of the page: the XML prologue and doctype removed (they are not
/// allowed inside HTML), the rest kept as written.
fn inline_svg(svg: &str) -> &str {
    svg.find("<svg").map_or("", |i| &svg[i..])
}

fn list_section(h: &mut String, title: &str, v: Option<&Value>) {
    let items = strings(v);
    if items.is_empty() {
        return;
    }
    let _ = write!(h, "<h2>{}</h2>", esc(title));
    list(h, v, "");
}

/// A bulleted list of the strings in `v` (nothing when there are none), after an optional label.
fn list(h: &mut String, v: Option<&Value>, label: &str) {
    let items = strings(v);
    if items.is_empty() {
        return;
    }
    if !label.is_empty() {
        let _ = write!(h, "<p><b>{}:</b></p>", esc(label));
    }
    h.push_str("<ul>");
    for i in items {
        let _ = write!(h, "<li>{}</li>", esc(&i));
    }
    h.push_str("</ul>");
}

fn strings(v: Option<&Value>) -> Vec<String> {
    v.and_then(Value::as_array)
        .map(|a| a.iter().filter_map(Value::as_str).map(str::to_owned).collect())
        .unwrap_or_default()
}

/// The string at `path` under `v`, if there is one.
fn text(v: &Value, path: &[&str]) -> Option<String> {
    let mut cur = v;
    for p in path {
        cur = cur.get(p)?;
    }
    match cur {
        Value::String(s) => Some(s.clone()),
        Value::Number(n) => Some(n.to_string()),
        Value::Bool(b) => Some(b.to_string()),
        _ => None,
    }
}

/// The finite number under `key` (JSON has no NaN: a `null` is no number).
fn num(v: &Value, key: &str) -> Option<f64> {
    v.get(key).and_then(Value::as_f64).filter(|x| x.is_finite())
}

/// `[a, b]` seconds as "a–b s".
fn span_s(v: &Value) -> String {
    match v
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_f64).collect::<Vec<_>>())
    {
        Some(a) if a.len() == 2 => format!("{:.1}–{:.1} s", a[0], a[1]),
        _ => String::new(),
    }
}

/// A number with `decimals` decimals, or a dash when it is missing.
fn opt(x: Option<f64>, decimals: usize) -> String {
    x.map_or_else(|| "—".into(), |x| format!("{x:.decimals$}"))
}

/// A number to three significant digits, or a dash.
fn opt_sig(x: Option<f64>) -> String {
    x.map_or_else(|| "—".into(), sig3)
}

fn sig3(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-2..1e4).contains(&a) {
        let digits = if a == 0.0 {
            0
        } else {
            (2 - a.log10().floor() as i32).max(0) as usize
        };
        format!("{x:.digits$}")
    } else {
        format!("{x:.2e}")
    }
}

/// "value ± σ unit"; a missing σ is said to be undetermined rather than printed as a number, and a
/// missing value is a dash.
fn value_sigma(value: Option<&Value>, sigma: Option<&Value>, unit: Option<&str>) -> String {
    let unit = unit.map(|u| format!(" {}", esc(u))).unwrap_or_default();
    match (
        value.and_then(Value::as_f64).filter(|x| x.is_finite()),
        sigma.and_then(Value::as_f64).filter(|x| x.is_finite()),
    ) {
        (Some(v), Some(s)) => format!("{} ± {}{unit}", sig3(v), sig3(s)),
        // A value without a finite σ is not an estimate: not shown as a number.
        (Some(_), None) => "not determined".into(),
        (None, _) if value.is_some_and(Value::is_null) => "not determined".into(),
        (None, _) => "—".into(),
    }
}

/// `s` with the five characters that HTML gives a meaning replaced by entities.
pub fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn text_is_escaped() {
        assert_eq!(esc("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
        let r = json!({"source": "<script>alert(1)</script>", "verdict": "x & y", "notes": ["<b>"]});
        let page = gaps_page(&r, &[]);
        assert!(!page.contains("<script>"), "{page}");
        assert!(page.contains("&lt;script&gt;alert(1)&lt;/script&gt;"));
        assert!(page.contains("x &amp; y"));
        assert!(page.contains("<li>&lt;b&gt;</li>"));
    }

    #[test]
    fn verdict_comes_first_and_sections_follow_in_order() {
        let r = json!({
            "source": "f.csv",
            "verdict": "C_D misses α²",
            "named": [{"what": "α²", "location": "C_D", "kind": "LiftQuadratic", "value": 1.5, "sigma": 0.1, "t2": 200.0}],
            "data_quality": {"samples": 100, "supports_verdict": true, "warnings": []},
            "coefficients": [{"name": "C_D", "cv_r2_baseline": 0.5, "cv_r2_extended": 0.9,
                              "added": [{"term": "α²", "value": 1.5, "sigma": null}], "verdict": "α² missing"}],
            "compatibility": {"outputs": [], "found": [], "rejected": []},
            "notes": ["n1"],
        });
        let page = gaps_page(
            &r,
            &[(
                "gap_CD.svg".into(),
                "<?xml version=\"1.0\"?><svg viewBox=\"0 0 1 1\"></svg>".into(),
            )],
        );
        let at = |s: &str| page.find(s).unwrap_or_else(|| panic!("`{s}` missing from {page}"));
        assert!(at("id=\"verdict\"") < at("id=\"data-quality\""));
        assert!(at("id=\"data-quality\"") < at("id=\"causes\""));
        assert!(at("id=\"causes\"") < at("id=\"coefficients\""));
        assert!(at("id=\"coefficients\"") < at("id=\"compatibility\""));
        assert!(at("id=\"compatibility\"") < at("id=\"figures\""));
        assert!(page.contains("class=\"verdict found\""));
        // An undetermined σ is said, not printed as a number.
        assert!(page.contains("α² = not determined"), "{page}");
        assert!(page.contains("1.50 ± 0.100"));
        assert!(page.contains("0.5000") && page.contains("0.9000"));
        // The figure is inline, without its XML prologue.
        assert!(page.contains("<figure><svg viewBox"));
        assert!(!page.contains("<?xml"));
    }

    #[test]
    fn a_diverged_simulation_says_where_and_has_no_r2() {
        let r = json!({"simulation": {"outputs": [{
            "channel": "Airspeed", "unit": "m/s",
            "baseline": {"r2": 0.9, "rms": 0.2, "pse": 0.1, "n": 10},
            "extended": {"r2": null, "rms": null, "pse": null, "n": 0},
            "diverged": [0, 1], "diverged_at_s": [[], [61.24]],
        }]}});
        let page = gaps_page(&r, &[]);
        assert!(
            page.contains("Airspeed with the extended models diverged at t = 61.2 s"),
            "{page}"
        );
        assert!(
            page.contains("<td class=\"num\">0.900</td><td class=\"num\">diverged</td>"),
            "{page}"
        );
        assert!(!page.contains("NaN"), "{page}");
    }

    #[test]
    fn missing_fields_leave_sections_out() {
        let page = gaps_page(&json!({}), &[]);
        assert!(page.contains("no verdict recorded"));
        assert!(!page.contains("id=\"coefficients\""));
        assert!(!page.contains("id=\"figures\""));
        assert!(page.ends_with("</body></html>\n"));
    }

    #[test]
    fn status_and_reasons_are_read() {
        let r = json!({"verdict": "none", "status": "no_verdict", "reasons": ["log too short"]});
        let page = gaps_page(&r, &[]);
        assert!(page.contains("class=\"verdict none\""));
        assert!(page.contains("<li>log too short</li>"), "{page}");
    }

    #[test]
    fn no_verdict_is_amber() {
        let r = json!({"verdict": "no verdict: too short", "data_quality": {"supports_verdict": false, "why_not": ["too short"]}});
        let page = gaps_page(&r, &[]);
        assert!(page.contains("class=\"verdict none\""));
        // The reason already in the verdict is not repeated under it, nor in the data quality.
        assert_eq!(page.matches("too short").count(), 1, "{page}");
        let r = json!({"verdict": "no verdict: see below", "data_quality": {"supports_verdict": false, "why_not": ["too short"]}});
        let page = gaps_page(&r, &[]);
        assert_eq!(page.matches("too short").count(), 1, "{page}");
    }
}
