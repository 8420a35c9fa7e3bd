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
//! A linear y axis is set by the 1st–99th percentile of the panel's data widened by a margin
//! ([`robust_range`]), so a start-up transient does not squeeze the rest of the flight into a line;
//! points beyond it are drawn on the edge and marked with a triangle, and the panel's caption says
//! so. Long traces are decimated for drawing to the first, lowest, highest and last point of each
//! pixel column ([`decimate`]): a spike stays visible and an hour at 100 Hz stays well under 1 MB.
//! The legend goes to the corner of the panel that covers the fewest points, or above the data
//! when every corner covers some; a band or line with nothing drawable gets no legend entry.
//! [`Figure::split_at`] marks the identification / held-out split on every panel. A title too
//! long for the figure is wrapped, a panel caption shrunk.
//!
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
//! use aerosid_report::plot::{Band, Colour, Figure, HLine, Line, Panel};
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
//! # Ok::<(), aerosid_report::plot::PlotError>(())
//! ```

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Opacity of a band's fill (0 = invisible, 1 = opaque).
const BAND_ALPHA: f64 = 0.25;
/// Dash length and gap of dashed lines, in pixels.
const DASH_PX: (u32, u32) = (8, 5);
/// The opacity that marks a dashed line's polylines in the SVG for [`dash_marked`]: no other
/// element is drawn with it.
const DASH_MARK_ALPHA: f64 = 0.999;
/// Font family of all text; the SVG viewer resolves it.
const FONT: &str = "sans-serif";
/// Width of a character as a share of the font size: an upper estimate for sans-serif text, used to
/// fit titles and to size legends without a font loader.
const CHAR_EM: f64 = 0.56;
/// Quantiles of the data that set a linear y axis ([`robust_range`]).
const ROBUST_QUANTILES: (f64, f64) = (0.01, 0.99);
/// How far beyond the robust quantiles data are still shown unclipped, as a share of their spread.
const ROBUST_MARGIN: f64 = 0.25;
/// Width of the y label area and the right margin, pixels: the plot area is the rest.
const Y_LABEL_PX: u32 = 75;
const RIGHT_PX: u32 = 20;

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

    /// [`Panel::band_polygons`] of the band cut to `columns` pixel columns: per column the lowest
    /// lower and the highest upper edge, at the column's first and last x, so the drawn band covers
    /// at least what the full band does.
    fn band_polygons_decimated(&self, band: &Band, x_range: &Range<f64>, columns: usize) -> Vec<Vec<(f64, f64)>> {
        let span = x_range.end - x_range.start;
        if band.x.len() <= 4 * columns || columns == 0 || span.is_nan() || span <= 0.0 {
            return self.band_polygons(band);
        }
        let column = |x: f64| ((x - x_range.start) / span * columns as f64).floor() as i64;
        let mut x = Vec::new();
        let mut lower = Vec::new();
        let mut upper = Vec::new();
        let mut i = 0;
        let n = band.x.len().min(band.lower.len()).min(band.upper.len());
        let ok = |i: usize| band.x[i].is_finite() && self.usable(band.lower[i]) && self.usable(band.upper[i]);
        while i < n {
            if !ok(i) {
                x.push(f64::NAN);
                lower.push(f64::NAN);
                upper.push(f64::NAN);
                i += 1;
                continue;
            }
            let c = column(band.x[i]);
            let (mut lo, mut hi, mut j) = (band.lower[i], band.upper[i], i + 1);
            while j < n && ok(j) && column(band.x[j]) == c {
                lo = lo.min(band.lower[j]);
                hi = hi.max(band.upper[j]);
                j += 1;
            }
            x.extend([band.x[i], band.x[j - 1]]);
            lower.extend([lo, lo]);
            upper.extend([hi, hi]);
            i = j;
        }
        self.band_polygons(&Band::new("", &x, &lower, &upper, band.colour))
    }

    /// The range of the data shown unclipped: all of it on a log axis, the [`robust_range`] of the
    /// lines and bands (with every reference line) on a linear one.
    fn data_range(&self) -> Option<(f64, f64)> {
        if self.log_y {
            return min_max(self.y_values().into_iter());
        }
        let mut data = Vec::new();
        for s in &self.series {
            match s {
                Series::Line(l) => data.extend(l.x.iter().zip(&l.y).filter(|(x, _)| x.is_finite()).map(|(_, y)| *y)),
                Series::Band(b) => {
                    for ((x, lo), hi) in b.x.iter().zip(&b.lower).zip(&b.upper) {
                        if x.is_finite() {
                            data.extend([*lo, *hi]);
                        }
                    }
                }
                Series::HLine(_) => {}
            }
        }
        data.retain(|y| y.is_finite());
        let hlines = self.series.iter().filter_map(|s| match s {
            Series::HLine(h) if h.y.is_finite() => Some(h.y),
            _ => None,
        });
        let robust = robust_range(&mut data);
        min_max(robust.into_iter().flat_map(|(lo, hi)| [lo, hi]).chain(hlines))
    }

    /// The y range to show: the data range with 5 % margin (in log space on a log axis), or a default
    /// when the panel has nothing drawable.
    fn y_range(&self) -> Range<f64> {
        let (lo, hi) = self
            .data_range()
            .unwrap_or(if self.log_y { (1.0, 10.0) } else { (0.0, 1.0) });
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
    split_x: Option<f64>,
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
            split_x: None,
        }
    }

    /// Mark the end of the identification segment and the start of the held-out one at `x` on every
    /// panel (a dashed vertical line, labelled on the top panel). A non-finite `x` marks nothing.
    pub fn split_at(mut self, x: f64) -> Self {
        self.split_x = x.is_finite().then_some(x);
        self
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
        let x_range = self.x_range()?;
        // A title wider than the figure is wrapped onto as many lines as it needs.
        let title_lines = self
            .title
            .as_deref()
            .map_or_else(Vec::new, |t| wrap(t, self.width_px, TITLE_PT));
        let title_px = if title_lines.is_empty() {
            0
        } else {
            12 + TITLE_LINE_PX * title_lines.len() as u32
        };
        let height_px = title_px + self.panel_height_px * self.panels.len() as u32 + 30;
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (self.width_px, height_px)).into_drawing_area();
            root.fill(&WHITE).map_err(render_err)?;
            let (head, body) = root.split_vertically(title_px);
            let style = TextStyle::from((FONT, TITLE_PT)).pos(Pos::new(HPos::Center, VPos::Top));
            for (i, line) in title_lines.iter().enumerate() {
                let y = 6 + TITLE_LINE_PX as i32 * i as i32;
                head.draw(&Text::new(line.as_str(), (self.width_px as i32 / 2, y), style.clone()))
                    .map_err(render_err)?;
            }
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
                let ctx = PanelContext {
                    x_label: (i == last).then_some(self.x_label.as_str()),
                    x_range: x_range.clone(),
                    columns: self.width_px as usize,
                    split: self.split_x.map(|x| (x, i == 0)),
                };
                self.draw_panel_area(&area, panel, &ctx)?;
            }
            root.present().map_err(render_err)?;
        }
        Ok(dash_marked(&svg))
    }

    /// The x range shared by every panel: the data's, widened about a single x. Errors: a series
    /// whose x and y lengths differ, or no data to draw.
    fn x_range(&self) -> Result<Range<f64>, PlotError> {
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
        Ok(x_lo..x_hi)
    }

    /// One panel in its `area`: the caption (noting clipped values), the axes (log or linear y)
    /// and [`draw_panel`].
    fn draw_panel_area(
        &self,
        area: &DrawingArea<SVGBackend<'_>, Shift>,
        panel: &Panel,
        ctx: &PanelContext<'_>,
    ) -> Result<(), PlotError> {
        let x_range = &ctx.x_range;
        let layout = panel.layout(ctx, self.width_px, area.dim_in_pixel().1);
        let caption = if layout.clipped {
            format!("{} (beyond the axis: ▲▼ on its edge)", panel.title)
        } else {
            panel.title.clone()
        };
        let caption_pt = fit_pt(&caption, self.width_px.saturating_sub(40), CAPTION_PT);
        let mut builder = ChartBuilder::on(area);
        builder
            .caption(&caption, (FONT, caption_pt))
            .margin(8)
            .margin_right(RIGHT_PX)
            .x_label_area_size(if ctx.x_label.is_some() { 45 } else { 25 })
            .y_label_area_size(Y_LABEL_PX);
        if panel.log_y {
            let mut chart = builder
                .build_cartesian_2d(x_range.clone(), layout.axis.clone().log_scale())
                .map_err(render_err)?;
            draw_panel(&mut chart, panel, ctx, &layout)?;
        } else {
            let mut chart = builder
                .build_cartesian_2d(x_range.clone(), layout.axis.clone())
                .map_err(render_err)?;
            draw_panel(&mut chart, panel, ctx, &layout)?;
        }
        Ok(())
    }
}

/// Font sizes (pt = px in SVG) of the figure title and the panel captions, and a title line's height.
const TITLE_PT: u32 = 22;
const TITLE_LINE_PX: u32 = 28;
const CAPTION_PT: u32 = 18;

/// What a panel is drawn with that the figure decides.
struct PanelContext<'s> {
    x_label: Option<&'s str>,
    x_range: Range<f64>,
    /// Pixel columns to decimate the traces to (the figure's width: at least the plot area's).
    columns: usize,
    /// The identification / held-out split, and whether this panel labels it.
    split: Option<(f64, bool)>,
}

/// The y axis of a panel and where its legend goes.
struct Layout {
    /// The range data are shown unclipped in: drawn values are clamped to it.
    data: Range<f64>,
    /// The axis: `data` padded, plus head room for the legend when every corner covers data.
    axis: Range<f64>,
    legend: SeriesLabelPosition,
    /// Whether any drawn value lies beyond `data`.
    clipped: bool,
}

impl Panel {
    /// The y axis and the legend's corner of this panel in an area of `width_px` × `height_px`.
    fn layout(&self, ctx: &PanelContext<'_>, width_px: u32, height_px: u32) -> Layout {
        let axis = self.y_range();
        let (dlo, dhi) = self.data_range().unwrap_or((axis.start, axis.end));
        let data = dlo.min(dhi)..dhi.max(dlo);
        let clipped = !self.log_y && self.y_values().iter().any(|y| *y < data.start || *y > data.end);
        // The legend's size as a share of the plot area (13 pt labels, a 20 px key, 18 px rows).
        let labels: Vec<&str> = self.legend_labels().collect();
        let plot_w = f64::from(width_px.saturating_sub(Y_LABEL_PX + RIGHT_PX + 16).max(50));
        let plot_h = f64::from(height_px.saturating_sub(80).max(50));
        let longest = labels.iter().map(|l| l.chars().count()).max().unwrap_or(0) as f64;
        let fx = ((longest * CHAR_EM * 13.0 + 45.0) / plot_w).min(1.0);
        let fy = ((labels.len() as f64 * 18.0 + 20.0) / plot_h).min(0.9);
        if labels.is_empty() {
            return Layout {
                data,
                axis,
                legend: SeriesLabelPosition::UpperRight,
                clipped,
            };
        }
        // Points (in the unit square of the plot area) under each corner's legend.
        let to_unit = |y: f64| {
            if self.log_y {
                (y.log10() - axis.start.log10()) / (axis.end.log10() - axis.start.log10())
            } else {
                (y.clamp(data.start, data.end) - axis.start) / (axis.end - axis.start)
            }
        };
        let xs = ctx.x_range.end - ctx.x_range.start;
        let mut counts = [0usize; 4];
        for (x, y) in self.points() {
            let (u, v) = ((x - ctx.x_range.start) / xs, to_unit(y));
            let right = u > 1.0 - fx;
            let left = u < fx;
            let top = v > 1.0 - fy;
            let bottom = v < fy;
            counts[0] += usize::from(top && right);
            counts[1] += usize::from(top && left);
            counts[2] += usize::from(bottom && right);
            counts[3] += usize::from(bottom && left);
        }
        let corners = [
            SeriesLabelPosition::UpperRight,
            SeriesLabelPosition::UpperLeft,
            SeriesLabelPosition::LowerRight,
            SeriesLabelPosition::LowerLeft,
        ];
        let best = (0..4).min_by_key(|&i| counts[i]).unwrap_or(0);
        if counts[best] == 0 || self.log_y {
            return Layout {
                data,
                axis,
                legend: corners[best].clone(),
                clipped,
            };
        }
        // Every corner covers data: raise the top of the axis so the legend sits above all of it.
        let head = (axis.end - axis.start) * fy / (1.0 - fy);
        Layout {
            data,
            axis: axis.start..axis.end + head,
            legend: SeriesLabelPosition::UpperRight,
            clipped,
        }
    }

    /// Labels of the series that will get a legend entry (labelled and with something to draw).
    fn legend_labels(&self) -> impl Iterator<Item = &str> + '_ {
        self.series.iter().filter_map(|s| match s {
            Series::Line(l) if !l.label.is_empty() && !self.line_pieces(&l.x, &l.y).is_empty() => {
                Some(l.label.as_str())
            }
            Series::Band(b) if !b.label.is_empty() && !self.band_polygons(b).is_empty() => Some(b.label.as_str()),
            Series::HLine(h) if !h.label.is_empty() && self.usable(h.y) => Some(h.label.as_str()),
            _ => None,
        })
    }

    /// Every drawable (x, y) of the lines and band edges.
    fn points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.series
            .iter()
            .flat_map(|s| -> Box<dyn Iterator<Item = (f64, f64)> + '_> {
                match s {
                    Series::Line(l) => Box::new(l.x.iter().copied().zip(l.y.iter().copied())),
                    Series::Band(b) => Box::new(
                        b.x.iter()
                            .zip(&b.lower)
                            .zip(&b.upper)
                            .flat_map(|((x, lo), hi)| [(*x, *lo), (*x, *hi)]),
                    ),
                    Series::HLine(_) => Box::new(std::iter::empty()),
                }
            })
            .filter(|(x, y)| x.is_finite() && self.usable(*y))
    }
}

/// A panel's plot area on the SVG backend.
type Chart<'a, 'b, Y> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, Y>>;

/// Draw the mesh, the series, the split and the legend of one panel on a chart whose y axis is `Y`
/// (linear or log; the data are `f64` either way).
fn draw_panel<'a, 'b: 'a, Y>(
    chart: &mut Chart<'a, 'b, Y>,
    panel: &Panel,
    ctx: &PanelContext<'_>,
    layout: &Layout,
) -> Result<(), PlotError>
where
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    draw_mesh(chart, panel, ctx, layout)?;
    if let Some((x, labelled)) = ctx.split {
        draw_split(chart, x, labelled, layout)?;
    }
    let series_of = SeriesOf { panel, ctx, layout };
    let mut labelled = false;
    for series in &panel.series {
        labelled |= match series {
            Series::Band(b) => series_of.draw_band(chart, b)?,
            Series::Line(l) => series_of.draw_line(chart, l)?,
            Series::HLine(h) => {
                let style = h.colour.rgb_color().stroke_width(1);
                let x_range = &ctx.x_range;
                let pieces = if panel.usable(h.y) {
                    vec![vec![(x_range.start, h.y), (x_range.end, h.y)]]
                } else {
                    Vec::new()
                };
                draw_path(chart, pieces, style, h.dashed, &h.label)?
            }
        };
    }
    if labelled {
        chart
            .configure_series_labels()
            .position(layout.legend.clone())
            .label_font((FONT, 13))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .draw()
            .map_err(render_err)?;
    }
    Ok(())
}

/// The grid, the axes' ticks and their descriptions.
fn draw_mesh<'a, 'b: 'a, Y>(
    chart: &mut Chart<'a, 'b, Y>,
    panel: &Panel,
    ctx: &PanelContext<'_>,
    layout: &Layout,
) -> Result<(), PlotError>
where
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let x_range = &ctx.x_range;
    // Tick values are computed in floating point, so the tick at zero can come out as ±1e-17.
    let x_zero = 1e-9 * (x_range.end - x_range.start).abs();
    let y_zero = if panel.log_y {
        0.0
    } else {
        1e-9 * layout.axis.end.abs().max(layout.axis.start.abs())
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
    if let Some(x) = ctx.x_label {
        mesh.x_desc(x);
    }
    mesh.draw().map_err(render_err)
}

/// The identification / held-out split at `x`: a dashed vertical line, named on each side when
/// `labelled`.
fn draw_split<'a, 'b: 'a, Y>(
    chart: &mut Chart<'a, 'b, Y>,
    x: f64,
    labelled: bool,
    layout: &Layout,
) -> Result<(), PlotError>
where
    Y: Ranged<ValueType = f64>,
{
    let style = RGBColor(60, 60, 60).stroke_width(1);
    let top = layout.axis.end;
    let line = vec![(x, layout.axis.start), (x, top)];
    chart
        .draw_series(std::iter::once(PathElement::new(
            line,
            ShapeStyle {
                color: style.color.mix(DASH_MARK_ALPHA),
                ..style
            },
        )))
        .map_err(render_err)?;
    if labelled {
        let font = TextStyle::from((FONT, 13)).color(&RGBColor(60, 60, 60));
        let left = font.pos(Pos::new(HPos::Right, VPos::Top));
        let right = font.pos(Pos::new(HPos::Left, VPos::Top));
        chart
            .draw_series([
                EmptyElement::at((x, top)) + Text::new("identification ◂", (-4, 4), left),
                EmptyElement::at((x, top)) + Text::new("▸ held out", (4, 4), right),
            ])
            .map_err(render_err)?;
    }
    Ok(())
}

/// What a panel's series are drawn against: the panel, its x range and columns, its y layout.
struct SeriesOf<'p> {
    panel: &'p Panel,
    ctx: &'p PanelContext<'p>,
    layout: &'p Layout,
}

impl SeriesOf<'_> {
    /// `y` clamped to the range data are shown unclipped in (log axes: unchanged).
    fn clamp(&self, y: f64) -> f64 {
        if self.panel.log_y {
            y
        } else {
            y.clamp(self.layout.data.start, self.layout.data.end)
        }
    }

    /// A ±σ band as filled polygons, its values clamped to the data range; returns whether it was
    /// labelled.
    fn draw_band<'a, 'b: 'a, Y: Ranged<ValueType = f64>>(
        &self,
        chart: &mut Chart<'a, 'b, Y>,
        b: &Band,
    ) -> Result<bool, PlotError> {
        let (panel, ctx) = (self.panel, self.ctx);
        let fill = b.colour.rgb_color().mix(BAND_ALPHA).filled();
        let polys: Vec<Vec<(f64, f64)>> = panel
            .band_polygons_decimated(b, &ctx.x_range, ctx.columns)
            .into_iter()
            .map(|p| p.into_iter().map(|(x, y)| (x, self.clamp(y))).collect())
            .collect();
        let drawn = !polys.is_empty();
        let anno = chart
            .draw_series(polys.into_iter().map(|p| Polygon::new(p, fill)))
            .map_err(render_err)?;
        if !b.label.is_empty() && drawn {
            anno.label(&b.label)
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], fill));
            return Ok(true);
        }
        Ok(false)
    }

    /// A line, decimated to the pixel columns and clamped to the data range, with a triangle on the
    /// edge where it is clipped; returns whether it was labelled.
    fn draw_line<'a, 'b: 'a, Y: Ranged<ValueType = f64>>(
        &self,
        chart: &mut Chart<'a, 'b, Y>,
        l: &Line,
    ) -> Result<bool, PlotError> {
        let (panel, ctx) = (self.panel, self.ctx);
        let x_range = &ctx.x_range;
        let style = l.colour.rgb_color().stroke_width(l.width_px);
        let mut marks = Vec::new();
        let pieces: Vec<Vec<(f64, f64)>> = panel
            .line_pieces(&l.x, &l.y)
            .iter()
            .map(|p| {
                decimate(p, x_range, ctx.columns)
                    .into_iter()
                    .map(|(x, y)| {
                        let c = self.clamp(y);
                        if c != y {
                            marks.push((x, c, y > c));
                        }
                        (x, c)
                    })
                    .collect()
            })
            .collect();
        let labelled = draw_path(chart, pieces, style, l.dashed, &l.label)?;
        // A clipped point: a triangle on the edge, pointing out of the axis, one per column.
        marks.dedup_by(|a, b| {
            a.2 == b.2 && ((a.0 - b.0) / (x_range.end - x_range.start) * ctx.columns as f64).abs() < 6.0
        });
        let fill = l.colour.rgb_color().filled();
        chart
            .draw_series(marks.into_iter().map(|(x, y, up)| {
                let tip = if up { -7 } else { 7 };
                EmptyElement::at((x, y)) + Polygon::new(vec![(-4, 0), (4, 0), (0, tip)], fill)
            }))
            .map_err(render_err)?;
        Ok(labelled)
    }
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
    let drawn = !pieces.is_empty();
    // A dashed line is one polyline with a dash pattern (set by `Figure::to_svg` on the polylines
    // this alpha marks), not a polyline per dash: a noisy hour-long trace made tens of thousands.
    let style = if dashed {
        ShapeStyle {
            color: style.color.mix(DASH_MARK_ALPHA),
            ..style
        }
    } else {
        style
    };
    let anno = chart
        .draw_series(pieces.into_iter().map(|p| PathElement::new(p, style)))
        .map_err(render_err)?;
    if label.is_empty() || !drawn {
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

/// The range of `values` to show unclipped: their 1st–99th percentile widened by a quarter of that
/// spread each side, and no wider than the values themselves. A start-up transient or a divergence
/// that takes under 1 % of the samples then lies beyond it instead of setting the axis. Non-finite
/// values are ignored; `values` is sorted in place. `None` when none is finite.
pub fn robust_range(values: &mut [f64]) -> Option<(f64, f64)> {
    let mut n = 0;
    for i in 0..values.len() {
        if values[i].is_finite() {
            values.swap(n, i);
            n += 1;
        }
    }
    let v = &mut values[..n];
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    // Quantile by the nearest rank at or inside the quantile (type 1 of Hyndman and Fan).
    let q = |p: f64| v[((p * (n - 1) as f64).round() as usize).min(n - 1)];
    let (lo, hi) = (q(ROBUST_QUANTILES.0), q(ROBUST_QUANTILES.1));
    let margin = ROBUST_MARGIN * (hi - lo);
    Some(((lo - margin).max(v[0]), (hi + margin).min(v[n - 1])))
}

/// Min/max decimation of a polyline for drawing at `columns` pixel columns across `x_range`: each
/// run of consecutive points in one column is cut to its first, lowest, highest and last point, in
/// their order, so the drawn envelope is the same and a one-sample spike is kept. Lines of at most
/// four points per column are returned as they are.
pub fn decimate(points: &[(f64, f64)], x_range: &Range<f64>, columns: usize) -> Vec<(f64, f64)> {
    let span = x_range.end - x_range.start;
    if points.len() <= 4 * columns || columns == 0 || span.is_nan() || span <= 0.0 {
        return points.to_vec();
    }
    let column = |x: f64| ((x - x_range.start) / span * columns as f64).floor() as i64;
    let mut out = Vec::with_capacity(4 * columns + 4);
    let mut start = 0;
    while start < points.len() {
        let c = column(points[start].0);
        let mut end = start + 1;
        while end < points.len() && column(points[end].0) == c {
            end += 1;
        }
        let run = &points[start..end];
        let (mut lo, mut hi) = (0, 0);
        for (i, p) in run.iter().enumerate() {
            if p.1 < run[lo].1 {
                lo = i;
            }
            if p.1 > run[hi].1 {
                hi = i;
            }
        }
        let mut keep = [0, lo.min(hi), lo.max(hi), run.len() - 1];
        keep.sort_unstable();
        let mut last = usize::MAX;
        for k in keep {
            if k != last {
                out.push(run[k]);
                last = k;
            }
        }
        start = end;
    }
    out
}

/// `svg` with the polylines of dashed lines (drawn with [`DASH_MARK_ALPHA`]) made opaque and dashed.
fn dash_marked(svg: &str) -> String {
    let (dash, gap) = DASH_PX;
    svg.replace(
        &format!("opacity=\"{DASH_MARK_ALPHA}\""),
        &format!("opacity=\"1\" stroke-dasharray=\"{dash} {gap}\""),
    )
}

/// The lines of `text` at `pt` points that fit `width_px`, broken at spaces.
fn wrap(text: &str, width_px: u32, pt: u32) -> Vec<String> {
    let max_chars = ((f64::from(width_px) - 20.0) / (CHAR_EM * f64::from(pt))).max(10.0) as usize;
    let mut lines: Vec<String> = Vec::new();
    let mut cur = String::new();
    for word in text.split(' ') {
        if !cur.is_empty() && cur.chars().count() + 1 + word.chars().count() > max_chars {
            lines.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(word);
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// The largest font size up to `pt` (and at least 11) at which `text` fits `width_px`.
fn fit_pt(text: &str, width_px: u32, pt: u32) -> u32 {
    let chars = text.chars().count().max(1) as f64;
    let fit = f64::from(width_px) / (CHAR_EM * chars);
    (fit.floor() as u32).clamp(11, pt)
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

    #[test]
    fn decimation_keeps_spikes_and_the_envelope() {
        // 100 000 samples of a sine with one-sample spikes, drawn on 500 columns.
        let n = 100_000;
        let mut pts: Vec<(f64, f64)> = (0..n).map(|i| (i as f64 * 0.01, (i as f64 * 0.001).sin())).collect();
        pts[12_345].1 = 40.0;
        pts[77_777].1 = -30.0;
        let range = 0.0..(n - 1) as f64 * 0.01;
        let d = decimate(&pts, &range, 500);
        assert!(d.len() <= 4 * 500 + 4, "{} points kept", d.len());
        // The spikes survive, at their own x.
        assert!(d.contains(&pts[12_345]) && d.contains(&pts[77_777]));
        // Every kept point is an original one, in the original order.
        assert!(d.windows(2).all(|w| w[0].0 < w[1].0));
        // Per column the extremes are those of the full trace.
        let col = |x: f64| (x / range.end * 500.0).floor() as usize;
        let mut full = vec![(f64::INFINITY, f64::NEG_INFINITY); 501];
        let mut kept = full.clone();
        for (m, p) in [(&mut full, &pts), (&mut kept, &d)] {
            for &(x, y) in p.iter() {
                let c = &mut m[col(x)];
                *c = (c.0.min(y), c.1.max(y));
            }
        }
        assert_eq!(full, kept);
        // First and last points are kept, so the line spans the same x.
        assert_eq!((d[0], d[d.len() - 1]), (pts[0], pts[n - 1]));
        // A short line is left alone.
        assert_eq!(decimate(&pts[..1000], &range, 500), pts[..1000].to_vec());
    }

    #[test]
    fn robust_range_ignores_a_start_up_transient() {
        // 0.5 % of the samples at −60 (a transient), the rest around 2 ± 0.1.
        let mut v: Vec<f64> = (0..10_000)
            .map(|i| {
                if i < 50 {
                    -60.0
                } else {
                    2.0 + 0.1 * (i as f64 * 0.37).sin()
                }
            })
            .collect();
        let (lo, hi) = robust_range(&mut v).unwrap_or_default();
        // 1st percentile ≈ 1.9, 99th ≈ 2.1, widened by a quarter of their spread.
        assert!((1.84..1.91).contains(&lo), "lo {lo}");
        assert!((2.09..2.16).contains(&hi), "hi {hi}");
        // Data all within the margin: the range is exactly theirs (nothing clipped).
        let mut w = vec![1.0, 2.0, 3.0, f64::NAN, 4.0];
        assert_eq!(robust_range(&mut w), Some((1.0, 4.0)));
        assert_eq!(robust_range(&mut [f64::NAN]), None);
    }

    #[test]
    fn transient_is_clipped_and_marked_not_set_the_axis() {
        let t: Vec<f64> = (0..1000).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|&t| if t < 0.5 { -60.0 } else { 1.9 + 0.1 * (t).sin() })
            .collect();
        let p = Panel::new("C_D", "C_D [-]").line(Line::new("estimate", &t, &y, Colour::BLUE));
        let r = p.y_range();
        assert!(r.start > 1.5 && r.end < 2.3, "{r:?}");
        let svg = Figure::new("t [s]").panel(p).to_svg().unwrap_or_default();
        assert!(svg.contains("beyond the axis"), "clipping not said");
    }

    #[test]
    fn empty_band_gets_no_legend_entry() {
        let t = [0.0, 1.0, 2.0];
        let nan = [f64::NAN; 3];
        let p = Panel::new("p", "y [m]")
            .band(Band::around("±2σ", &t, &[1.0, 2.0, 3.0], &nan, 2.0, Colour::BLUE))
            .line(Line::new("estimate", &t, &[1.0, 2.0, 3.0], Colour::BLUE));
        let svg = Figure::new("t [s]").panel(p).to_svg().unwrap_or_default();
        assert!(svg.contains("estimate"));
        assert!(!svg.contains("±2σ"), "legend entry for a band with nothing drawn");
    }

    #[test]
    fn long_titles_wrap_and_captions_shrink() {
        let title = "held-out segment simulated with the fitted models (5 s pieces, each from the measured state)";
        let lines = wrap(title, 900, TITLE_PT);
        assert!(lines.len() >= 2, "{lines:?}");
        for l in &lines {
            assert!(l.chars().count() as f64 * CHAR_EM * f64::from(TITLE_PT) <= 880.0, "{l}");
        }
        assert_eq!(lines.join(" "), title);
        assert_eq!(fit_pt("short", 800, CAPTION_PT), CAPTION_PT);
        assert!(fit_pt(&"x".repeat(120), 800, CAPTION_PT) < CAPTION_PT);
    }

    #[test]
    fn an_hour_at_100_hz_makes_a_small_svg() {
        let t: Vec<f64> = (0..360_000).map(|i| i as f64 * 0.01).collect();
        // Noise on every sample (a fixed sequence), so each pixel column spans a range.
        let y: Vec<f64> = t.iter().map(|t| (t * 0.7).sin() + 0.1 * (t * 1e4).sin()).collect();
        let z: Vec<f64> = y.iter().map(|v| v * 0.9).collect();
        let sigma = vec![0.05; t.len()];
        let fig = Figure::new("time [s]")
            .split_at(2000.0)
            .panel(
                Panel::new("a", "a [m]")
                    .band(Band::around("±2σ", &t, &y, &sigma, 2.0, Colour::BLUE))
                    .line(Line::new("measured", &t, &y, Colour::GREY))
                    .line(Line::new("model", &t, &z, Colour::BLUE).dashed()),
            )
            .panel(Panel::new("b", "b [m]").line(Line::new("residual", &t, &z, Colour::VERMILLION)));
        let svg = fig.to_svg().unwrap_or_default();
        assert!(!svg.is_empty() && svg.len() < 1_000_000, "{} bytes", svg.len());
        assert!(svg.contains("held out"));
        // The dashed line is one polyline dashed by SVG: tens of polylines (axes, legend keys, one per
        // trace), not the thousands a polyline per dash of a noisy trace gave.
        assert!(svg.contains("stroke-dasharray=\"8 5\""));
        assert!(!svg.contains(&format!("opacity=\"{DASH_MARK_ALPHA}\"")));
        assert!(
            svg.matches("<polyline").count() < 100,
            "{} polylines",
            svg.matches("<polyline").count()
        );
    }
}
