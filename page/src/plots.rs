//! The report's figures as inline SVG, drawn with `plotters`' SVG backend: text stays
//! `<text>` (no fonts are loaded or embedded), so a figure is a few kilobytes.
//! A figure that cannot be drawn becomes a short note instead of failing the report.

use plotters::coord::Shift;
use plotters::prelude::*;

/// A drawing area on an SVG string.
type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
/// What drawing code returns.
type Drawn = Result<(), Box<dyn std::error::Error>>;

/// Width of a full-width figure, px.
pub const WIDE: u32 = 640;
/// Width of a figure in a row of two, px.
pub const HALF: u32 = 420;

const FONT: &str = "sans-serif";
const BLUE: RGBColor = RGBColor(31, 119, 180);
const ORANGE: RGBColor = RGBColor(255, 127, 14);
const RED: RGBColor = RGBColor(214, 39, 40);
const GREY: RGBColor = RGBColor(150, 150, 150);

/// Ten distinguishable line colours (matplotlib's tab10).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Draws into a fresh `width × height` SVG; a drawing error becomes a note.
fn svg(width: u32, height: u32, draw: impl FnOnce(&Area) -> Drawn) -> String {
    let mut text = String::new();
    let result = {
        let root = SVGBackend::with_string(&mut text, (width, height)).into_drawing_area();
        root.fill(&WHITE)
            .map_err(|e| e.into())
            .and_then(|_| draw(&root))
            .and_then(|_| root.present().map_err(|e| e.into()))
    };
    match result {
        Ok(()) => text,
        Err(e) => format!(
            "<p class=\"warn\">this figure could not be drawn: {}</p>",
            super::html::escape(&e.to_string())
        ),
    }
}

/// `points` less those that land on the pixel of an earlier one, in order. A marker
/// drawn again on the same pixel adds nothing a reader can see (only its antialiased
/// edge gets a shade darker), so a scatter of 10^4 runs is drawn with one marker per
/// pixel it covers: its SVG and the report stop growing with the runs, and an outlier
/// is still drawn.
fn one_per_pixel<X, Y>(
    chart: &ChartContext<'_, SVGBackend<'_>, Cartesian2d<X, Y>>,
    points: impl IntoIterator<Item = (f64, f64)>,
) -> Vec<(f64, f64)>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let mut taken = std::collections::HashSet::new();
    points
        .into_iter()
        .filter(|point| taken.insert(chart.backend_coord(point)))
        .collect()
}

/// `[lo, hi]` widened by 5 % on each side, and never empty.
fn padded(lo: f64, hi: f64) -> std::ops::Range<f64> {
    let (lo, hi) = if lo.is_finite() && hi.is_finite() {
        (lo, hi)
    } else {
        (0.0, 1.0)
    };
    let span = hi - lo;
    let pad = if span > 0.0 {
        0.05 * span
    } else {
        0.5 * lo.abs().max(1e-12)
    };
    (lo - pad)..(hi + pad)
}

fn extent(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
}

/// Tick labels with four significant digits.
pub fn tick(v: &f64) -> String {
    super::html::number(*v)
}

/// Viridis, from five stops, at `t` in [0, 1].
pub fn viridis(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let scaled = t * (STOPS.len() - 1) as f64;
    let i = (scaled.floor() as usize).min(STOPS.len() - 2);
    let f = scaled - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let mix = |x: f64, y: f64| (x + (y - x) * f).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// A heat map of `z(x, y)` over a box, with the design points (white circles) and the
/// optimum (a red cross), and a colour bar.
#[allow(clippy::too_many_arguments)]
pub fn heatmap(
    title: &str,
    x_label: &str,
    x_range: (f64, f64),
    y_label: &str,
    y_range: (f64, f64),
    z_label: &str,
    z: impl Fn(f64, f64) -> f64,
    points: &[(f64, f64)],
    optimum: Option<(f64, f64)>,
) -> String {
    const N: usize = 32;
    let (x0, x1) = x_range;
    let (y0, y1) = y_range;
    let dx = (x1 - x0) / N as f64;
    let dy = (y1 - y0) / N as f64;
    let cells: Vec<(f64, f64, f64)> = (0..N)
        .flat_map(|i| (0..N).map(move |j| (i, j)))
        .map(|(i, j)| {
            let (x, y) = (x0 + (i as f64 + 0.5) * dx, y0 + (j as f64 + 0.5) * dy);
            (x, y, z(x, y))
        })
        .collect();
    let (z0, z1) = extent(cells.iter().map(|c| c.2));
    let scale = |v: f64| if z1 > z0 { (v - z0) / (z1 - z0) } else { 0.5 };
    svg(WIDE, 440, |root| {
        let (plot, bar) = root.split_horizontally(WIDE - 130);
        let mut chart = ChartBuilder::on(&plot)
            .caption(title, (FONT, 16))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .x_labels(6)
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .label_style((FONT, 12))
            .draw()?;
        chart.draw_series(cells.iter().map(|&(x, y, v)| {
            Rectangle::new(
                [(x - dx / 2.0, y - dy / 2.0), (x + dx / 2.0, y + dy / 2.0)],
                viridis(scale(v)).filled(),
            )
        }))?;
        chart.draw_series(
            one_per_pixel(&chart, points.iter().copied())
                .into_iter()
                .map(|(x, y)| Circle::new((x, y), 5, ShapeStyle::from(&WHITE).stroke_width(2))),
        )?;
        if let Some((x, y)) = optimum {
            chart.draw_series(std::iter::once(Cross::new(
                (x, y),
                8,
                ShapeStyle::from(&RED).stroke_width(3),
            )))?;
        }
        // The colour bar.
        let mut legend = ChartBuilder::on(&bar)
            .margin_top(36)
            .margin_bottom(50)
            .margin_left(20)
            .y_label_area_size(0)
            .right_y_label_area_size(80)
            .build_cartesian_2d(0.0..1.0, padded(z0, z1).start..padded(z0, z1).end)?
            .set_secondary_coord(0.0..1.0, z0..z1.max(z0 + f64::EPSILON));
        legend
            .configure_secondary_axes()
            .y_desc(z_label)
            .y_label_formatter(&tick)
            .label_style((FONT, 11))
            .draw()?;
        let steps = 50;
        legend.draw_secondary_series((0..steps).map(|k| {
            let a = z0 + (z1 - z0) * k as f64 / steps as f64;
            let b = z0 + (z1 - z0) * (k + 1) as f64 / steps as f64;
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                viridis((k as f64 + 0.5) / steps as f64).filled(),
            )
        }))?;
        Ok(())
    })
}

/// A line chart: named lines, optional observed points and a vertical marker.
pub fn lines(
    title: &str,
    x_label: &str,
    y_label: &str,
    lines: &[(String, Vec<(f64, f64)>)],
    points: &[(f64, f64)],
    marker: Option<f64>,
    width: u32,
) -> String {
    let all = lines.iter().flat_map(|(_, l)| l.iter()).chain(points);
    let (x0, x1) = extent(all.clone().map(|p| p.0));
    let (y0, y1) = extent(all.map(|p| p.1));
    svg(width, 300, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 15))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(padded(x0, x1), padded(y0, y1))?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .x_labels(6)
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .label_style((FONT, 11))
            .light_line_style(WHITE)
            .draw()?;
        if let Some(x) = marker {
            let (a, b) = (padded(y0, y1).start, padded(y0, y1).end);
            chart.draw_series(LineSeries::new(
                vec![(x, a), (x, b)],
                ShapeStyle::from(&RED).stroke_width(1),
            ))?;
        }
        for (k, (name, line)) in lines.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let series = chart.draw_series(LineSeries::new(
                line.iter().copied(),
                ShapeStyle::from(&colour).stroke_width(2),
            ))?;
            if lines.len() > 1 {
                series.label(name.as_str()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2))
                });
            }
        }
        chart.draw_series(
            one_per_pixel(&chart, points.iter().copied())
                .into_iter()
                .map(|(x, y)| Circle::new((x, y), 4, BLACK.filled())),
        )?;
        if lines.len() > 1 {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(GREY)
                .label_font((FONT, 11))
                .position(SeriesLabelPosition::UpperLeft)
                .draw()?;
        }
        Ok(())
    })
}

/// Predicted (leave-one-out) against observed, with the line `y = x`.
pub fn predicted_observed(title: &str, unit_label: &str, pairs: &[(f64, f64)]) -> String {
    let (lo, hi) = extent(pairs.iter().flat_map(|p| [p.0, p.1]));
    let range = padded(lo, hi);
    svg(HALF, 360, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 15))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(range.clone(), range.clone())?;
        chart
            .configure_mesh()
            .x_desc(format!("observed {unit_label}"))
            .y_desc(format!("predicted, leave-one-out {unit_label}"))
            .x_labels(6)
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .label_style((FONT, 11))
            .light_line_style(WHITE)
            .draw()?;
        chart.draw_series(LineSeries::new(
            vec![(range.start, range.start), (range.end, range.end)],
            GREY.stroke_width(1),
        ))?;
        chart.draw_series(
            one_per_pixel(&chart, pairs.iter().copied())
                .into_iter()
                .map(|(o, p)| Circle::new((o, p), 4, BLUE.filled())),
        )?;
        Ok(())
    })
}

/// Horizontal bars of |t| per term, largest first (the Pareto chart of standardised
/// effects), with a line at |t| = 2 (about 95 % significance).
pub fn pareto(title: &str, effects: &[(String, f64)]) -> String {
    let n = effects.len().max(1);
    let top = effects
        .iter()
        .map(|e| e.1.abs())
        .filter(|v| v.is_finite())
        .fold(2.5_f64, f64::max)
        * 1.1;
    svg(HALF, 60 + 28 * n as u32 + 50, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 15))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(10)
            .build_cartesian_2d(0.0..top, -0.5..(n as f64 - 0.5))?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .y_labels(0)
            .x_desc("|t| (coefficient / its standard error)")
            .x_label_formatter(&tick)
            .label_style((FONT, 11))
            .light_line_style(WHITE)
            .draw()?;
        for (i, (name, t)) in effects.iter().enumerate() {
            let y = (n - 1 - i) as f64;
            let colour = if *t >= 0.0 { BLUE } else { ORANGE };
            let length = if t.is_finite() { t.abs() } else { top };
            chart.draw_series(std::iter::once(Rectangle::new(
                [(0.0, y - 0.35), (length, y + 0.35)],
                colour.mix(0.8).filled(),
            )))?;
            chart.draw_series(std::iter::once(Text::new(
                format!("{name} ({})", tick(t)),
                (top * 0.01, y + 0.1),
                (FONT, 12).into_font().color(&BLACK),
            )))?;
        }
        chart.draw_series(LineSeries::new(
            vec![(2.0, -0.5), (2.0, n as f64 - 0.5)],
            RED.stroke_width(1),
        ))?;
        Ok(())
    })
}

/// One factor's Sobol indices for the sensitivity chart: its name, and the first-order
/// and total index each as `(estimate, low, high)`.
pub type SobolBar = (String, (f64, f64, f64), (f64, f64, f64));

/// Sobol indices per factor as paired horizontal bars (first order dark, total light)
/// on a 0–1 axis, with their 95 % intervals as whiskers.
pub fn sobol(title: &str, bars: &[SobolBar]) -> String {
    let n = bars.len().max(1);
    svg(HALF, 60 + 40 * n as u32 + 50, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 15))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(10)
            .build_cartesian_2d(0.0..1.05, -0.5..(n as f64 - 0.5))?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .y_labels(0)
            .x_desc("share of the variance (dark: factor alone; light: with interactions)")
            .x_label_formatter(&tick)
            .label_style((FONT, 11))
            .light_line_style(WHITE)
            .draw()?;
        for (i, (name, first, total)) in bars.iter().enumerate() {
            let y = (n - 1 - i) as f64;
            for ((value, low, high), (offset, shade)) in
                [(*total, (0.17, 0.35)), (*first, (-0.17, 0.9))]
            {
                let value = value.clamp(0.0, 1.05);
                chart.draw_series(std::iter::once(Rectangle::new(
                    [(0.0, y + offset - 0.15), (value, y + offset + 0.15)],
                    BLUE.mix(shade).filled(),
                )))?;
                if high > low {
                    chart.draw_series(LineSeries::new(
                        vec![
                            (low.clamp(0.0, 1.05), y + offset),
                            (high.clamp(0.0, 1.05), y + offset),
                        ],
                        BLACK.stroke_width(1),
                    ))?;
                }
            }
            chart.draw_series(std::iter::once(Text::new(
                format!("{name} ({} / {})", tick(&first.0), tick(&total.0)),
                (0.62, y + 0.1),
                (FONT, 12).into_font().color(&BLACK),
            )))?;
        }
        Ok(())
    })
}

/// One round in the trust-region chart: its name, its box `[(x0, x1), (y0, y1)]` and
/// its optimum `(x, y)`, natural units.
pub type RoundBox = (String, [(f64, f64); 2], Option<(f64, f64)>);

/// Each round's box as a rectangle inside the factor limits (two factors), with each
/// round's optimum as a cross.
pub fn boxes(x_label: &str, y_label: &str, limits: [(f64, f64); 2], rounds: &[RoundBox]) -> String {
    svg(HALF + 60, 400, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption("Trust region of each round", (FONT, 15))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                padded(limits[0].0, limits[0].1),
                padded(limits[1].0, limits[1].1),
            )?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .x_labels(6)
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .label_style((FONT, 11))
            .light_line_style(WHITE)
            .draw()?;
        chart.draw_series(std::iter::once(Rectangle::new(
            [(limits[0].0, limits[1].0), (limits[0].1, limits[1].1)],
            ShapeStyle::from(&BLACK).stroke_width(1),
        )))?;
        for (k, (name, b, optimum)) in rounds.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            chart.draw_series(std::iter::once(Rectangle::new(
                [(b[0].0, b[1].0), (b[0].1, b[1].1)],
                colour.mix(0.15).filled(),
            )))?;
            chart.draw_series(std::iter::once(Rectangle::new(
                [(b[0].0, b[1].0), (b[0].1, b[1].1)],
                colour.stroke_width(2),
            )))?;
            // The round's name inside its box's upper left corner: no legend to hide a cross.
            chart.draw_series(std::iter::once(
                EmptyElement::at((b[0].0, b[1].1))
                    + Text::new(name.clone(), (4, 4), (FONT, 11).into_font().color(&colour)),
            ))?;
            if let Some(o) = optimum {
                chart.draw_series(std::iter::once(Cross::new(*o, 7, RED.stroke_width(3))))?;
            }
        }
        Ok(())
    })
}

/// One factor's range per round as a vertical bar inside its limits (for studies with
/// other than two factors), with each round's optimum as a cross.
pub fn intervals(
    y_label: &str,
    limits: (f64, f64),
    rounds: &[((f64, f64), Option<f64>)],
) -> String {
    let n = rounds.len().max(1);
    svg(HALF, 300, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(format!("Trust region: {y_label}"), (FONT, 14))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.5..(n as f64 - 0.5), padded(limits.0, limits.1))?;
        chart
            .configure_mesh()
            .x_desc("round")
            .y_desc(y_label)
            .x_labels(n)
            .x_label_formatter(&|v| format!("{}", v.round() as i64))
            .y_label_formatter(&tick)
            .label_style((FONT, 11))
            .light_line_style(WHITE)
            .draw()?;
        for (k, ((lo, hi), optimum)) in rounds.iter().enumerate() {
            let x = k as f64;
            chart.draw_series(std::iter::once(Rectangle::new(
                [(x - 0.2, *lo), (x + 0.2, *hi)],
                BLUE.mix(0.3).filled(),
            )))?;
            if let Some(o) = optimum {
                chart.draw_series(std::iter::once(Cross::new((x, *o), 7, RED.stroke_width(3))))?;
            }
        }
        Ok(())
    })
}

/// A two-objective Pareto front in objective space: its points (blue dots) joined in
/// order along the front, and the compromise point (a red cross).
pub fn front(
    title: &str,
    x_label: &str,
    y_label: &str,
    points: &[(f64, f64)],
    compromise: Option<(f64, f64)>,
) -> String {
    let all = points.iter().chain(compromise.iter());
    let (x0, x1) = extent(all.clone().map(|p| p.0));
    let (y0, y1) = extent(all.map(|p| p.1));
    svg(HALF, 360, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 15))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(padded(x0, x1), padded(y0, y1))?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .x_labels(6)
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .label_style((FONT, 11))
            .light_line_style(WHITE)
            .draw()?;
        chart.draw_series(LineSeries::new(
            points.iter().copied(),
            BLUE.mix(0.5).stroke_width(1),
        ))?;
        chart.draw_series(
            points
                .iter()
                .map(|&(x, y)| Circle::new((x, y), 4, BLUE.filled())),
        )?;
        if let Some(c) = compromise {
            chart.draw_series(std::iter::once(Cross::new(c, 7, RED.stroke_width(3))))?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_runs_from_dark_purple_to_yellow() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(f64::NAN), viridis(0.0));
    }

    #[test]
    fn a_figure_is_one_svg_element_with_its_title_as_text() {
        let svg = pareto(
            "Pareto chart <x & y>",
            &[("a".into(), 3.0), ("b".into(), -1.0)],
        );
        assert!(svg.starts_with("<svg"), "{svg}");
        assert_eq!(svg.matches("<svg").count(), 1);
        assert!(svg.contains("Pareto chart &lt;x &amp; y&gt;"), "{svg}");
    }

    #[test]
    fn a_front_of_one_point_still_draws() {
        let svg = front("front", "a", "b", &[(1.0, 2.0)], Some((1.0, 2.0)));
        assert!(svg.starts_with("<svg"), "{svg}");
        assert!(front("front", "a", "b", &[], None).starts_with("<svg"));
    }

    /// 10^4 runs along the diagonal of a 420-px figure cover a few hundred pixels:
    /// each is drawn once, and an outlier among them is still drawn.
    #[test]
    fn a_scatter_draws_one_marker_per_pixel_and_keeps_an_outlier() {
        let n = 10_000;
        let mut pairs: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                let o = k as f64 / n as f64;
                (o, o + 1e-4 * (k % 7) as f64)
            })
            .collect();
        let circles = |svg: &str| svg.matches("<circle").count();
        let diagonal = circles(&predicted_observed("p", "[m]", &pairs));
        assert!((100..1000).contains(&diagonal), "{diagonal} markers");
        pairs.push((0.2, 0.9));
        assert_eq!(
            circles(&predicted_observed("p", "[m]", &pairs)),
            diagonal + 1
        );
        // Points on distinct pixels are all drawn.
        let few: Vec<(f64, f64)> = (0..20).map(|k| (k as f64, (k * k) as f64)).collect();
        assert_eq!(circles(&predicted_observed("p", "[m]", &few)), 20);
    }

    #[test]
    fn a_flat_surface_still_draws() {
        let svg = heatmap(
            "flat",
            "x",
            (0.0, 1.0),
            "y",
            (0.0, 1.0),
            "z",
            |_, _| 2.0,
            &[],
            None,
        );
        assert!(svg.starts_with("<svg"), "{svg}");
    }
}
