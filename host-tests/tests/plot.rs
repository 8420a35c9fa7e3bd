//! The figure writer: a multi-panel SVG with a band, a log axis and gaps from NaNs, and the
//! documented refusals (empty figure, unwritable path).

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use aerosid::plot::{Band, Colour, Figure, HLine, Line, Panel, PlotError};

/// A fresh directory under the system temp dir, unique per process and call.
fn temp_dir(tag: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("aerosid-plot-{tag}-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A figure with the four kinds of content the project draws: a parameter history with a ±2σ band
/// and truth, singular values on a log axis with a threshold, λ_F, and measured vs predicted.
fn sample_figure() -> Figure {
    let t: Vec<f64> = (0..200).map(|i| f64::from(i) * 0.05).collect();
    let est: Vec<f64> = t.iter().map(|&t| 1.0 - (-t).exp() * (3.0 * t).cos()).collect();
    let sigma: Vec<f64> = t.iter().map(|&t| 0.5 * (-0.5 * t).exp()).collect();
    let mut with_gap = est.clone();
    with_gap[50] = f64::NAN; // a dropped sample
    with_gap[51] = f64::INFINITY;
    let sv_small: Vec<f64> = t.iter().map(|&t| 1e-4 * (1.0 + t * t)).collect();
    let mut sv_large: Vec<f64> = t.iter().map(|&t| 1.0 + t).collect();
    sv_large[0] = 0.0; // not drawable on a log axis
    sv_large[1] = f64::NAN;
    let lambda: Vec<f64> = t.iter().map(|&t| 0.999 - 0.01 * (-t).exp()).collect();
    let measured: Vec<f64> = t.iter().map(|&t| (2.0 * t).sin()).collect();
    let predicted: Vec<f64> = t.iter().map(|&t| 0.95 * (2.0 * t).sin()).collect();
    let residual: Vec<f64> = measured.iter().zip(&predicted).map(|(m, p)| m - p).collect();

    Figure::new("time [s]")
        .title("aerosid test figure")
        .panel(
            Panel::new("Lift slope estimate", "C_Lα [1/rad]")
                .band(Band::around("±2σ", &t, &est, &sigma, 2.0, Colour::BLUE))
                .line(Line::new("GTLS estimate", &t, &with_gap, Colour::BLUE))
                .hline(HLine::new("truth", 1.0, Colour::BLACK).dashed()),
        )
        .panel(
            Panel::new("Singular values", "σ_i")
                .log_y()
                .line(Line::new("σ_min", &t, &sv_small, Colour::VERMILLION))
                .line(Line::new("σ_max", &t, &sv_large, Colour::GREEN))
                .hline(HLine::new("excitation threshold", 1e-3, Colour::BLACK).dashed()),
        )
        .panel(Panel::new("Forgetting factor", "λ_F").line(Line::new("λ_F", &t, &lambda, Colour::ORANGE)))
        .panel(
            Panel::new("Pitch rate", "q [rad/s]")
                .line(Line::new("measured", &t, &measured, Colour::GREY))
                .line(Line::new("predicted", &t, &predicted, Colour::BLUE).dashed()),
        )
        .panel(Panel::new("Residual", "Δq [rad/s]").line(Line::new("residual", &t, &residual, Colour::PURPLE)))
}

#[test]
fn writes_a_multi_panel_svg_with_band_log_axis_and_gaps() {
    // GIVEN a five-panel figure with a band, a log axis and non-finite samples
    let dir = temp_dir("ok");
    let path = dir.join("nested").join("figure.svg");

    // WHEN it is written
    sample_figure().write_svg(&path).unwrap();

    // THEN the file is an SVG document carrying every title and legend label
    let svg = std::fs::read_to_string(&path).unwrap();
    assert!(svg.starts_with("<svg"), "starts with {:?}", &svg[..svg.len().min(40)]);
    assert!(svg.trim_end().ends_with("</svg>"));
    for text in [
        "aerosid test figure",
        "Lift slope estimate",
        "Singular values",
        "Forgetting factor",
        "Pitch rate",
        "Residual",
        "±2σ",
        "GTLS estimate",
        "truth",
        "σ_min",
        "σ_max",
        "excitation threshold",
        "λ_F",
        "measured",
        "predicted",
        "time [s]",
    ] {
        assert!(svg.contains(text), "missing `{text}`");
    }
    assert!(
        !svg.contains("NaN") && !svg.contains("inf"),
        "a non-finite value reached the SVG"
    );
    // The band is a translucent polygon.
    assert!(
        svg.contains("<polygon") && svg.contains("opacity=\"0.25"),
        "no translucent band"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn empty_figures_are_refused() {
    // No panels at all.
    assert!(matches!(Figure::new("t").to_svg(), Err(PlotError::EmptyFigure)));
    // Panels whose only data are non-finite, or non-positive on a log axis, or only a reference line.
    let fig = Figure::new("t")
        .panel(Panel::new("nan", "y").line(Line::new("a", &[0.0, 1.0], &[f64::NAN, f64::NAN], Colour::BLUE)))
        .panel(
            Panel::new("log", "y")
                .log_y()
                .line(Line::new("b", &[0.0, 1.0], &[0.0, -1.0], Colour::BLUE)),
        )
        .panel(Panel::new("ref", "y").hline(HLine::new("c", 1.0, Colour::BLACK)))
        .panel(Panel::new("empty", "y").line(Line::new("d", &[], &[], Colour::BLUE)));
    let dir = temp_dir("empty");
    let path = dir.join("empty.svg");
    let err = fig.write_svg(&path).unwrap_err();
    assert!(matches!(err, PlotError::EmptyFigure), "{err}");
    assert!(!path.exists(), "nothing is written for a refused figure");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_panel_without_data_is_drawn_beside_one_with_data() {
    let fig = Figure::new("t")
        .panel(Panel::new("has data", "y").line(Line::new("a", &[0.0, 1.0], &[1.0, 2.0], Colour::BLUE)))
        .panel(
            Panel::new("all NaN", "y")
                .log_y()
                .line(Line::new("b", &[0.0, 1.0], &[f64::NAN, 0.0], Colour::BLUE)),
        );
    let svg = fig.to_svg().unwrap();
    assert!(svg.contains("has data") && svg.contains("all NaN"));
}

#[test]
fn mismatched_lengths_name_the_series() {
    let fig =
        Figure::new("t").panel(Panel::new("p", "y").line(Line::new("short", &[0.0, 1.0, 2.0], &[1.0], Colour::BLUE)));
    match fig.to_svg() {
        Err(PlotError::LengthMismatch {
            panel,
            series,
            x_len: 3,
            other_len: 1,
        }) => {
            assert_eq!((panel.as_str(), series.as_str()), ("p", "short"));
        }
        other => panic!("expected a length mismatch, got {other:?}"),
    }
}

#[test]
fn an_unwritable_path_is_reported_with_the_path() {
    // GIVEN a path whose parent is a regular file (unwritable even for root)
    let dir = temp_dir("unwritable");
    let blocker = dir.join("not-a-directory");
    std::fs::write(&blocker, b"x").unwrap();
    let path = blocker.join("figure.svg");

    // WHEN the figure is written there
    let err = sample_figure().write_svg(&path).unwrap_err();

    // THEN the error is an I/O error that names the path
    match &err {
        PlotError::Io { path: p, .. } => assert_eq!(p, &path),
        other => panic!("expected an I/O error, got {other:?}"),
    }
    assert!(err.to_string().contains(&*path.to_string_lossy()), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
