//! Figures: vertically stacked panels sharing one time axis, written as SVG.
//!
//! The figures of the project are products (STYLE.md, habit 13): a command builds a [`Figure`] from
//! data and calls [`Figure::write_svg`]; nothing here is committed by hand. The module covers the
//! plots the identification needs:
//!
//! * parameter time histories — a [`Line`] per estimate, a [`Band`] for ±kσ
//!   ([`Band::around`]), a dashed [`Line`] or an [`HLine`] for the truth;
//! * singular values of the information matrix on a log axis ([`Panel::log_y`]) with the excitation
//!   threshold as an [`HLine`];
//! * forgetting-factor (λ_F) trajectories;
//! * measured vs predicted outputs in one panel and their residuals in the panel below.
//!
//! # Data handling
//! Non-finite points (NaN, ±∞) are skipped and split a line or band into separate pieces, so a gap in
//! the data shows as a gap in the figure. On a log axis non-positive values are skipped the same way.
//! A figure with no panels, or with no drawable point at all, is refused with
//! [`PlotError::EmptyFigure`]; a series whose arrays differ in length is refused with
//! [`PlotError::LengthMismatch`]. Nothing here panics on data.
//!
//! # Output
//! Rendering uses `plotters` with only its SVG backend and no font loader: text is emitted as SVG
//! `<text>` elements laid out with a fixed width estimate, so no system fonts or libraries are needed
//! and the viewer picks the `sans-serif` face. There is no PNG output (a bitmap needs a rasterising
//! font loader); convert the SVG if a bitmap is wanted.
//!
//! ```no_run
//! use aerosid::plot::{Band, Colour, Figure, HLine, Line, Panel};
//! let t = [0.0, 0.1, 0.2];
//! let est = [0.9, 1.0, 1.05];
//! let sigma = [0.2, 0.1, 0.05];
//! let fig = Figure::new("time [s]").title("C_Lα").panel(
//!     Panel::new("lift slope", "C_Lα [1/rad]")
//!         .band(Band::around("±2σ", &t, &est, &sigma, 2.0, Colour::BLUE))
//!         .line(Line::new("estimate", &t, &est, Colour::BLUE))
//!         .hline(HLine::new("truth", 1.0, Colour::BLACK).dashed()),
//! );
//! fig.write_svg("figures/cla.svg")?;
//! # Ok::<(), aerosid::plot::PlotError>(())
//! ```

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

/// Opacity of a band's fill (0 = invisible, 1 = opaque).
const BAND_ALPHA: f64 = 0.25;
/// Dash length and gap of dashed lines, in pixels.
const DASH_PX: (u32, u32) = (8, 5);
/// Font family of all text; the SVG viewer resolves it.
const FONT: &str = "sans-serif";

/// Why a figure was not written.
#[derive(Debug)]
pub enum PlotError {
    /// The figure has no panels, or no panel has a single finite (and, on a log axis, positive) point.
    EmptyFigure,
    /// A series' arrays differ in length.
    LengthMismatch {
        /// Title of the panel holding the series.
        panel: String,
        /// Label of the series.
        series: String,
        /// Length of the x array.
        x_len: usize,
        /// Length of the other array (y, or the shorter of a band's lower/upper).
        other_len: usize,
    },
    /// `plotters` failed while drawing (the message is its own).
    Render(String),
    /// The file (or its parent directory) could not be written.
    Io {
        /// The path that was being written.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
}

impl fmt::Display for PlotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::EmptyFigure => write!(f, "empty figure: no panel has a drawable point"),
            Self::LengthMismatch {
                panel,
                series,
                x_len,
                other_len,
            } => write!(
                f,
                "series `{series}` in panel `{panel}`: x has {x_len} points but the values have {other_len}"
            ),
            Self::Render(msg) => write!(f, "drawing the figure failed: {msg}"),
            Self::Io { path, source } => write!(f, "cannot write figure `{}`: {source}", path.display()),
        }
    }
}

impl std::error::Error for PlotError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Self::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

fn render_err(e: impl fmt::Display) -> PlotError {
    PlotError::Render(e.to_string())
}

/// An sRGB colour. The named constants are the Okabe–Ito palette (distinguishable with the common
/// colour-vision deficiencies) plus black and grey; [`Colour::cycle`] walks through them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Colour {
    /// Red, 0–255.
    pub r: u8,
    /// Green, 0–255.
    pub g: u8,
    /// Blue, 0–255.
    pub b: u8,
}

impl Colour {
    /// Black, for truth lines and thresholds.
    pub const BLACK: Self = Self::rgb(0, 0, 0);
    /// Mid grey.
    pub const GREY: Self = Self::rgb(128, 128, 128);
    /// Okabe–Ito blue.
    pub const BLUE: Self = Self::rgb(0, 114, 178);
    /// Okabe–Ito vermillion.
    pub const VERMILLION: Self = Self::rgb(213, 94, 0);
    /// Okabe–Ito bluish green.
    pub const GREEN: Self = Self::rgb(0, 158, 115);
    /// Okabe–Ito orange.
    pub const ORANGE: Self = Self::rgb(230, 159, 0);
    /// Okabe–Ito reddish purple.
    pub const PURPLE: Self = Self::rgb(204, 121, 167);
    /// Okabe–Ito sky blue.
    pub const SKY_BLUE: Self = Self::rgb(86, 180, 233);

    const CYCLE: [Self; 6] = [
        Self::BLUE,
        Self::VERMILLION,
        Self::GREEN,
        Self::ORANGE,
        Self::PURPLE,
        Self::SKY_BLUE,
    ];

    /// A colour from its red, green and blue components.
    pub const fn rgb(r: u8, g: u8, b: u8) -> Self {
        Self { r, g, b }
    }

    /// The `i`-th colour of the palette, repeating after six.
    pub const fn cycle(i: usize) -> Self {
        Self::CYCLE[i % Self::CYCLE.len()]
    }

    fn rgb_color(self) -> RGBColor {
        RGBColor(self.r, self.g, self.b)
    }
}

/// A polyline through `(x[i], y[i])`, solid or dashed.
#[derive(Debug, Clone)]
pub struct Line {
    label: String,
    x: Vec<f64>,
    y: Vec<f64>,
    colour: Colour,
    dashed: bool,
    width_px: u32,
}

impl Line {
    /// A solid line, 2 px wide. `x` and `y` must have the same length (checked when written).
    pub fn new(label: impl Into<String>, x: &[f64], y: &[f64], colour: Colour) -> Self {
        Self {
            label: label.into(),
            x: x.to_vec(),
            y: y.to_vec(),
            colour,
            dashed: false,
            width_px: 2,
        }
    }

    /// Draw the line dashed (e.g. a truth history).
    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }

    /// Stroke width in pixels (at least 1).
    pub fn width(mut self, width_px: u32) -> Self {
        self.width_px = width_px.max(1);
        self
    }
}

/// A translucent region between `lower[i]` and `upper[i]` at `x[i]`.
#[derive(Debug, Clone)]
pub struct Band {
    label: String,
    x: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    colour: Colour,
}

impl Band {
    /// A band between `lower` and `upper`; all three arrays must have the same length.
    pub fn new(label: impl Into<String>, x: &[f64], lower: &[f64], upper: &[f64], colour: Colour) -> Self {
        Self {
            label: label.into(),
            x: x.to_vec(),
            lower: lower.to_vec(),
            upper: upper.to_vec(),
            colour,
        }
    }

    /// The band `centre ± k·sigma` (e.g. `k = 2` for ±2σ). The arrays are paired up to the shorter of
    /// `centre` and `sigma`; `x` must match that length.
    pub fn around(label: impl Into<String>, x: &[f64], centre: &[f64], sigma: &[f64], k: f64, colour: Colour) -> Self {
        let (lower, upper) = centre
            .iter()
            .zip(sigma)
            .map(|(c, s)| (c - k * s, c + k * s))
            .unzip::<_, _, Vec<_>, Vec<_>>();
        Self {
            label: label.into(),
            x: x.to_vec(),
            lower,
            upper,
            colour,
        }
    }
}

/// A horizontal reference line across the whole panel (a truth value, a threshold).
#[derive(Debug, Clone)]
pub struct HLine {
    label: String,
    y: f64,
    colour: Colour,
    dashed: bool,
}

impl HLine {
    /// A solid horizontal line at `y`.
    pub fn new(label: impl Into<String>, y: f64, colour: Colour) -> Self {
        Self {
            label: label.into(),
            y,
            colour,
            dashed: false,
        }
    }

    /// Draw the line dashed.
    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }
}

#[derive(Debug, Clone)]
enum Series {
    Line(Line),
    Band(Band),
    HLine(HLine),
}

/// One plot area of a [`Figure`]: a title, a y label, a linear or log y axis, and its series, drawn in
/// the order they were added (add bands first so lines stay on top).
#[derive(Debug, Clone)]
pub struct Panel {
    title: String,
    y_label: String,
    log_y: bool,
    series: Vec<Series>,
}

impl Panel {
    /// An empty panel with a linear y axis.
    pub fn new(title: impl Into<String>, y_label: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            y_label: y_label.into(),
            log_y: false,
            series: Vec::new(),
        }
    }

    /// Use a base-10 log y axis; non-positive values are then skipped.
    pub fn log_y(mut self) -> Self {
        self.log_y = true;
        self
    }

    /// Add a line.
    pub fn line(mut self, line: Line) -> Self {
        self.series.push(Series::Line(line));
        self
    }

    /// Add a band.
    pub fn band(mut self, band: Band) -> Self {
        self.series.push(Series::Band(band));
        self
    }

    /// Add a horizontal reference line.
    pub fn hline(mut self, hline: HLine) -> Self {
        self.series.push(Series::HLine(hline));
        self
    }

    /// Whether `y` can be drawn on this panel's axis.
    fn usable(&self, y: f64) -> bool {
        y.is_finite() && (!self.log_y || y > 0.0)
    }

    fn check_lengths(&self) -> Result<(), PlotError> {
        for s in &self.series {
            let (label, x_len, other_len) = match s {
                Series::Line(l) => (&l.label, l.x.len(), l.y.len()),
                Series::Band(b) => (&b.label, b.x.len(), b.lower.len().min(b.upper.len())),
                Series::HLine(_) => continue,
            };
            let band_uneven = matches!(s, Series::Band(b) if b.lower.len() != b.upper.len());
            if x_len != other_len || band_uneven {
                return Err(PlotError::LengthMismatch {
                    panel: self.title.clone(),
                    series: label.clone(),
                    x_len,
                    other_len,
                });
            }
        }
        Ok(())
    }

    /// Finite x values of the data series (horizontal lines span whatever range the others give).
    fn x_values(&self) -> impl Iterator<Item = f64> + '_ {
        self.series
            .iter()
            .flat_map(|s| match s {
                Series::Line(l) => l.x.as_slice(),
                Series::Band(b) => b.x.as_slice(),
                Series::HLine(_) => &[],
            })
            .copied()
            .filter(|x| x.is_finite())
    }

    /// Drawable y values, including reference lines.
    fn y_values(&self) -> Vec<f64> {
        let mut ys = Vec::new();
        for s in &self.series {
            match s {
                Series::Line(l) => ys.extend(l.x.iter().zip(&l.y).filter(|(x, _)| x.is_finite()).map(|(_, y)| *y)),
                Series::Band(b) => {
                    for ((x, lo), hi) in b.x.iter().zip(&b.lower).zip(&b.upper) {
                        if x.is_finite() {
                            ys.extend([*lo, *hi]);
                        }
                    }
                }
                Series::HLine(h) => ys.push(h.y),
            }
        }
        ys.retain(|y| self.usable(*y));
        ys
    }

    /// Pieces of a line: maximal runs of consecutive drawable points.
    fn line_pieces(&self, x: &[f64], y: &[f64]) -> Vec<Vec<(f64, f64)>> {
        let mut pieces = Vec::new();
        let mut cur = Vec::new();
        for (&xi, &yi) in x.iter().zip(y) {
            if xi.is_finite() && self.usable(yi) {
                cur.push((xi, yi));
            } else if !cur.is_empty() {
                pieces.push(std::mem::take(&mut cur));
            }
        }
        if !cur.is_empty() {
            pieces.push(cur);
        }
        pieces
    }

    /// Closed outlines of a band: for each run where x, lower and upper are all drawable, the upper
    /// edge forward then the lower edge backward.
    fn band_polygons(&self, band: &Band) -> Vec<Vec<(f64, f64)>> {
        let mut polys = Vec::new();
        let mut run: Vec<(f64, f64, f64)> = Vec::new();
        let flush = |run: &mut Vec<(f64, f64, f64)>, polys: &mut Vec<Vec<(f64, f64)>>| {
            if !run.is_empty() {
                let mut poly: Vec<(f64, f64)> = run.iter().map(|&(x, _, hi)| (x, hi)).collect();
                poly.extend(run.iter().rev().map(|&(x, lo, _)| (x, lo)));
                polys.push(poly);
                run.clear();
            }
        };
        for ((&x, &lo), &hi) in band.x.iter().zip(&band.lower).zip(&band.upper) {
            if x.is_finite() && self.usable(lo) && self.usable(hi) {
                run.push((x, lo, hi));
            } else {
                flush(&mut run, &mut polys);
            }
        }
        flush(&mut run, &mut polys);
        polys
    }

    /// The y range to show: the data range with 5 % margin (in log space on a log axis), or a default
    /// when the panel has nothing drawable.
    fn y_range(&self) -> Range<f64> {
        let ys = self.y_values();
        let (lo, hi) = min_max(ys.iter().copied()).unwrap_or(if self.log_y { (1.0, 10.0) } else { (0.0, 1.0) });
        if self.log_y {
            let (llo, lhi) = pad(lo.log10(), hi.log10(), 0.5);
            10f64.powf(llo)..10f64.powf(lhi)
        } else {
            let (lo, hi) = pad(lo, hi, 0.5 * lo.abs().max(hi.abs()).max(1e-12));
            lo..hi
        }
    }
}

/// A figure: one or more panels stacked vertically, all sharing the x (time) axis, which is labelled
/// under the bottom panel.
#[derive(Debug, Clone)]
pub struct Figure {
    title: Option<String>,
    x_label: String,
    width_px: u32,
    panel_height_px: u32,
    panels: Vec<Panel>,
}

impl Figure {
    /// An empty figure whose shared x axis is labelled `x_label` (e.g. `"time [s]"`); 900 px wide,
    /// 280 px per panel.
    pub fn new(x_label: impl Into<String>) -> Self {
        Self {
            title: None,
            x_label: x_label.into(),
            width_px: 900,
            panel_height_px: 280,
            panels: Vec::new(),
        }
    }

    /// A title over the whole figure.
    pub fn title(mut self, title: impl Into<String>) -> Self {
        self.title = Some(title.into());
        self
    }

    /// Figure width and the height of each panel, in pixels (each at least 200).
    pub fn size(mut self, width_px: u32, panel_height_px: u32) -> Self {
        self.width_px = width_px.max(200);
        self.panel_height_px = panel_height_px.max(200);
        self
    }

    /// Append a panel under the existing ones.
    pub fn panel(mut self, panel: Panel) -> Self {
        self.panels.push(panel);
        self
    }

    /// Render the figure and write it to `path` as SVG, creating missing parent directories.
    ///
    /// # Errors
    /// [`PlotError::EmptyFigure`], [`PlotError::LengthMismatch`] or [`PlotError::Render`] as for
    /// [`Figure::to_svg`]; [`PlotError::Io`] naming `path` when it cannot be written.
    pub fn write_svg(&self, path: impl AsRef<Path>) -> Result<(), PlotError> {
        let path = path.as_ref();
        let svg = self.to_svg()?;
        let io_err = |source| PlotError::Io {
            path: path.to_path_buf(),
            source,
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io_err)?;
        }
        std::fs::write(path, svg).map_err(io_err)
    }

    /// Render the figure to an SVG document.
    ///
    /// # Errors
    /// [`PlotError::EmptyFigure`] when there are no panels or nothing drawable in any of them,
    /// [`PlotError::LengthMismatch`] for a series with arrays of different lengths, and
    /// [`PlotError::Render`] if `plotters` fails.
    pub fn to_svg(&self) -> Result<String, PlotError> {
        for p in &self.panels {
            p.check_lengths()?;
        }
        let has_data = self
            .panels
            .iter()
            .any(|p| p.series.iter().any(|s| !matches!(s, Series::HLine(_))) && !p.y_values().is_empty());
        if !has_data {
            return Err(PlotError::EmptyFigure);
        }
        let (x_lo, x_hi) = min_max(self.panels.iter().flat_map(Panel::x_values)).ok_or(PlotError::EmptyFigure)?;
        let (x_lo, x_hi) = if x_lo < x_hi {
            (x_lo, x_hi)
        } else {
            pad(x_lo, x_hi, 0.5 * x_lo.abs().max(1.0))
        };
        let x_range = x_lo..x_hi;

        let title_px = if self.title.is_some() { 40 } else { 0 };
        let height_px = title_px + self.panel_height_px * self.panels.len() as u32 + 30;
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (self.width_px, height_px)).into_drawing_area();
            root.fill(&WHITE).map_err(render_err)?;
            let body = match &self.title {
                Some(t) => root.titled(t, (FONT, 24)).map_err(render_err)?,
                None => root.clone(),
            };
            // The bottom panel gets the extra 30 px for the shared x label.
            let last = self.panels.len() - 1;
            let mut rest = body;
            for (i, panel) in self.panels.iter().enumerate() {
                let area = if i == last {
                    rest.clone()
                } else {
                    let (top, bottom) = rest.split_vertically(self.panel_height_px);
                    rest = bottom;
                    top
                };
                let x_label = (i == last).then_some(self.x_label.as_str());
                let y_range = panel.y_range();
                let mut builder = ChartBuilder::on(&area);
                builder
                    .caption(&panel.title, (FONT, 18))
                    .margin(8)
                    .margin_right(20)
                    .x_label_area_size(if x_label.is_some() { 45 } else { 25 })
                    .y_label_area_size(75);
                if panel.log_y {
                    let mut chart = builder
                        .build_cartesian_2d(x_range.clone(), y_range.log_scale())
                        .map_err(render_err)?;
                    draw_panel(&mut chart, panel, x_label, &x_range)?;
                } else {
                    let mut chart = builder
                        .build_cartesian_2d(x_range.clone(), y_range)
                        .map_err(render_err)?;
                    draw_panel(&mut chart, panel, x_label, &x_range)?;
                }
            }
            root.present().map_err(render_err)?;
        }
        Ok(svg)
    }
}

/// Draw the mesh, the series and the legend of one panel on a chart whose y axis is `Y` (linear or
/// log; the data are `f64` either way).
fn draw_panel<'a, 'b: 'a, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, Y>>,
    panel: &Panel,
    x_label: Option<&str>,
    x_range: &Range<f64>,
) -> Result<(), PlotError>
where
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    // Tick values are computed in floating point, so the tick at zero can come out as ±1e-17.
    let x_zero = 1e-9 * (x_range.end - x_range.start).abs();
    let y_zero = if panel.log_y {
        0.0
    } else {
        let y = panel.y_range();
        1e-9 * y.end.abs().max(y.start.abs())
    };
    let x_tick = |v: &f64| format_tick(*v, x_zero);
    let y_tick = |v: &f64| format_tick(*v, y_zero);
    let mut mesh = chart.configure_mesh();
    mesh.y_desc(&panel.y_label)
        .x_label_formatter(&x_tick)
        .y_label_formatter(&y_tick)
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 15))
        .light_line_style(RGBColor(235, 235, 235));
    if let Some(x) = x_label {
        mesh.x_desc(x);
    }
    mesh.draw().map_err(render_err)?;

    let mut labelled = false;
    for series in &panel.series {
        match series {
            Series::Band(b) => {
                let fill = b.colour.rgb_color().mix(BAND_ALPHA).filled();
                let polys = panel.band_polygons(b);
                let anno = chart
                    .draw_series(polys.into_iter().map(|p| Polygon::new(p, fill)))
                    .map_err(render_err)?;
                if !b.label.is_empty() {
                    anno.label(&b.label)
                        .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], fill));
                    labelled = true;
                }
            }
            Series::Line(l) => {
                let style = l.colour.rgb_color().stroke_width(l.width_px);
                let pieces = panel.line_pieces(&l.x, &l.y);
                labelled |= draw_path(chart, pieces, style, l.dashed, &l.label)?;
            }
            Series::HLine(h) => {
                let style = h.colour.rgb_color().stroke_width(1);
                let pieces = if panel.usable(h.y) {
                    vec![vec![(x_range.start, h.y), (x_range.end, h.y)]]
                } else {
                    Vec::new()
                };
                labelled |= draw_path(chart, pieces, style, h.dashed, &h.label)?;
            }
        }
    }
    if labelled {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font((FONT, 13))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .draw()
            .map_err(render_err)?;
    }
    Ok(())
}

/// Draw the pieces of one polyline as a single legend entry; returns whether it was labelled.
fn draw_path<'a, 'b: 'a, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, Y>>,
    pieces: Vec<Vec<(f64, f64)>>,
    style: ShapeStyle,
    dashed: bool,
    label: &str,
) -> Result<bool, PlotError>
where
    Y: Ranged<ValueType = f64>,
{
    let (dash, gap) = DASH_PX;
    let anno = if dashed {
        chart.draw_series(pieces.into_iter().map(|p| DashedPathElement::new(p, dash, gap, style)))
    } else {
        chart.draw_series(pieces.into_iter().map(|p| PathElement::new(p, style)))
    }
    .map_err(render_err)?;
    if label.is_empty() {
        return Ok(false);
    }
    let legend = move |(x, y): (i32, i32)| {
        if dashed {
            // Two dashes, so the key reads as dashed at legend size.
            EmptyElement::at((x, y))
                + PathElement::new(vec![(0, 0), (8, 0)], style)
                + PathElement::new(vec![(12, 0), (20, 0)], style)
        } else {
            EmptyElement::at((x, y))
                + PathElement::new(vec![(0, 0), (10, 0)], style)
                + PathElement::new(vec![(10, 0), (20, 0)], style)
        }
    };
    anno.label(label).legend(legend);
    Ok(true)
}

/// Tick text: "0" within `zero_tol` of zero, plain decimals for moderate magnitudes, scientific
/// notation otherwise.
fn format_tick(v: f64, zero_tol: f64) -> String {
    let a = v.abs();
    if a <= zero_tol {
        "0".to_owned()
    } else if !(1e-3..1e4).contains(&a) {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_owned()
    }
}

/// Smallest and largest of the values, or `None` when there are none.
fn min_max(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values.fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

/// Widen `[lo, hi]` by 5 % each side; a degenerate interval is widened by `half_width_if_flat`.
fn pad(lo: f64, hi: f64, half_width_if_flat: f64) -> (f64, f64) {
    let span = hi - lo;
    if span > 0.0 {
        (lo - 0.05 * span, hi + 0.05 * span)
    } else {
        let h = if half_width_if_flat > 0.0 && half_width_if_flat.is_finite() {
            half_width_if_flat
        } else {
            1.0
        };
        (lo - h, hi + h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_short() {
        assert_eq!(format_tick(0.0, 0.0), "0");
        assert_eq!(format_tick(-2e-16, 1e-9), "0");
        assert_eq!(format_tick(0.25, 1e-9), "0.25");
        assert_eq!(format_tick(2.0, 0.0), "2");
        assert_eq!(format_tick(1e-6, 0.0), "1e-6");
        assert_eq!(format_tick(-12.5, 0.0), "-12.5");
    }

    #[test]
    fn nan_splits_a_line_into_pieces() {
        let p = Panel::new("p", "y");
        let pieces = p.line_pieces(&[0.0, 1.0, 2.0, 3.0, 4.0], &[1.0, f64::NAN, 2.0, 3.0, f64::INFINITY]);
        assert_eq!(pieces, vec![vec![(0.0, 1.0)], vec![(2.0, 2.0), (3.0, 3.0)]]);
    }

    #[test]
    fn log_axis_skips_non_positive_values() {
        let p = Panel::new("p", "y")
            .log_y()
            .line(Line::new("l", &[0.0, 1.0, 2.0], &[-1.0, 0.0, 1e-3], Colour::BLUE));
        assert_eq!(p.y_values(), vec![1e-3]);
        let r = p.y_range();
        assert!(r.start > 0.0 && r.start < 1e-3 && r.end > 1e-3);
    }

    #[test]
    fn band_outline_goes_up_then_back_down() {
        let p = Panel::new("p", "y");
        let b = Band::around("b", &[0.0, 1.0], &[1.0, 2.0], &[0.5, 0.5], 2.0, Colour::BLUE);
        assert_eq!(
            p.band_polygons(&b),
            vec![vec![(0.0, 2.0), (1.0, 3.0), (1.0, 1.0), (0.0, 0.0)]]
        );
    }
}
