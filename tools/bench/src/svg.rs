//! Error-against-time scatter plots as plain SVG: log-scaled axes, one colour per series, the
//! Pareto front (no other point both faster and more accurate) drawn as a line with its points
//! ringed. Written by hand rather than with a plotting crate: the output is a few hundred lines
//! of text and needs no fonts or rasterizer.

use std::fmt::Write;

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct Point {
    pub series: String,
    pub label: String,
    /// Time (ms): the x axis.
    pub x: f64,
    /// Error: the y axis.
    pub y: f64,
}

pub struct Plot<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub points: &'a [Point],
}

/// Indices of the points on the Pareto front (minimizing both x and y), sorted by x.
pub fn pareto_front(points: &[Point]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].x.is_finite() && points[i].y.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        points[a]
            .x
            .total_cmp(&points[b].x)
            .then(points[a].y.total_cmp(&points[b].y))
    });
    let mut front = Vec::new();
    let mut best_y = f64::INFINITY;
    for i in idx {
        if points[i].y < best_y {
            best_y = points[i].y;
            front.push(i);
        }
    }
    front
}

const PALETTE: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf",
];

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Log-scale range covering `values` (positive, finite), widened to whole decades.
fn decades(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v.log10());
        hi = hi.max(v.log10());
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let (lo, hi) = (lo.floor(), hi.ceil());
    if hi > lo { (lo, hi) } else { (lo, lo + 1.0) }
}

/// Renders the plot. Points with a non-positive or non-finite coordinate cannot sit on a log
/// axis; they are listed under the plot instead of being dropped silently.
pub fn render(plot: &Plot) -> String {
    let (w, h) = (900.0, 560.0);
    let (left, right, top, bottom) = (80.0, 250.0, 40.0, 70.0);
    let pw = w - left - right;
    let ph = h - top - bottom;
    let ok = |p: &Point| p.x.is_finite() && p.y.is_finite() && p.x > 0.0 && p.y > 0.0;
    let (x0, x1) = decades(plot.points.iter().filter(|p| ok(p)).map(|p| p.x));
    let (y0, y1) = decades(plot.points.iter().filter(|p| ok(p)).map(|p| p.y));
    let sx = |x: f64| left + (x.log10() - x0) / (x1 - x0) * pw;
    let sy = |y: f64| top + ph - (y.log10() - y0) / (y1 - y0) * ph;

    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="{w}" height="{h}" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="24" font-size="15" text-anchor="middle">{}</text>"#,
        left + pw / 2.0,
        escape(plot.title)
    );
    // Grid and tick labels at every decade (and 2, 5 in between when there are few decades).
    let minor: &[f64] = if x1 - x0 <= 3.0 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    };
    for d in (x0 as i32)..=(x1 as i32) {
        for &m in minor {
            let v = m * 10f64.powi(d);
            if v.log10() > x1 + 1e-9 {
                continue;
            }
            let x = sx(v);
            let _ = writeln!(
                s,
                r##"<line x1="{x:.1}" y1="{top}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                top + ph,
                top + ph + 16.0,
                tick(v)
            );
        }
    }
    let minor_y: &[f64] = if y1 - y0 <= 3.0 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    };
    for d in (y0 as i32)..=(y1 as i32) {
        for &m in minor_y {
            let v = m * 10f64.powi(d);
            if v.log10() > y1 + 1e-9 {
                continue;
            }
            let y = sy(v);
            let _ = writeln!(
                s,
                r##"<line x1="{left}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
                left + pw,
                left - 6.0,
                y + 4.0,
                tick(v)
            );
        }
    }
    let _ = writeln!(
        s,
        r##"<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="none" stroke="#333"/>"##
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{} (log)</text>"#,
        left + pw / 2.0,
        h - 25.0,
        escape(plot.x_label)
    );
    let _ = writeln!(
        s,
        r#"<text transform="translate(20 {:.1}) rotate(-90)" text-anchor="middle">{} (log)</text>"#,
        top + ph / 2.0,
        escape(plot.y_label)
    );

    let mut series: Vec<&str> = Vec::new();
    for p in plot.points {
        if !series.contains(&p.series.as_str()) {
            series.push(&p.series);
        }
    }
    let colour = |name: &str| {
        let i = series.iter().position(|s| *s == name).unwrap_or(0);
        PALETTE[i % PALETTE.len()]
    };

    let plotted: Vec<Point> = plot.points.iter().filter(|p| ok(p)).cloned().collect();
    let front = pareto_front(&plotted);
    if front.len() > 1 {
        let path: Vec<String> = front
            .iter()
            .map(|&i| format!("{:.1},{:.1}", sx(plotted[i].x), sy(plotted[i].y)))
            .collect();
        let _ = writeln!(
            s,
            r##"<polyline points="{}" fill="none" stroke="#000" stroke-width="1.5" stroke-dasharray="5 3"/>"##,
            path.join(" ")
        );
    }
    for (i, p) in plotted.iter().enumerate() {
        let (x, y) = (sx(p.x), sy(p.y));
        let c = colour(&p.series);
        let _ = writeln!(
            s,
            r#"<circle cx="{x:.1}" cy="{y:.1}" r="4" fill="{c}" stroke="{c}"/>"#
        );
        if front.contains(&i) {
            let _ = writeln!(
                s,
                r##"<circle cx="{x:.1}" cy="{y:.1}" r="7" fill="none" stroke="#000"/><text x="{:.1}" y="{:.1}" font-size="10">{}</text>"##,
                x + 8.0,
                y - 6.0,
                escape(&p.label)
            );
        }
    }
    // Legend.
    let lx = left + pw + 20.0;
    for (i, name) in series.iter().enumerate() {
        let y = top + 10.0 + i as f64 * 18.0;
        let c = colour(name);
        let _ = writeln!(
            s,
            r#"<circle cx="{lx}" cy="{y}" r="4" fill="{c}" stroke="{c}"/><text x="{}" y="{}">{}</text>"#,
            lx + 10.0,
            y + 4.0,
            escape(name)
        );
    }
    let y = top + 14.0 + series.len() as f64 * 18.0;
    let _ = writeln!(
        s,
        r##"<line x1="{}" y1="{y}" x2="{}" y2="{y}" stroke="#000" stroke-dasharray="5 3"/><text x="{}" y="{}">Pareto front</text>"##,
        lx - 6.0,
        lx + 6.0,
        lx + 10.0,
        y + 4.0
    );
    let skipped: Vec<&Point> = plot.points.iter().filter(|p| !ok(p)).collect();
    for (i, p) in skipped.iter().take(8).enumerate() {
        let _ = writeln!(
            s,
            r#"<text x="{lx}" y="{}" font-size="10">not plotted: {} {} (x {}, y {})</text>"#,
            y + 24.0 + i as f64 * 14.0,
            escape(&p.series),
            escape(&p.label),
            p.x,
            p.y
        );
    }
    s.push_str("</svg>\n");
    s
}

fn tick(v: f64) -> String {
    if v >= 1.0 {
        format!("{v:.0}")
    } else {
        let digits = (-v.log10()).ceil() as usize;
        format!("{v:.digits$}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Point {
        Point {
            series: "s".into(),
            label: format!("{x},{y}"),
            x,
            y,
        }
    }

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let pts = [
            p(1.0, 5.0),
            p(2.0, 3.0),
            p(3.0, 4.0),
            p(4.0, 1.0),
            p(0.5, 9.0),
        ];
        assert_eq!(pareto_front(&pts), vec![4, 0, 1, 3]);
    }

    #[test]
    fn render_marks_front_and_lists_unplottable_points() {
        let pts = [p(1.0, 5.0), p(2.0, 0.0), p(4.0, 1.0)];
        let svg = render(&Plot {
            title: "t",
            x_label: "ms",
            y_label: "LSB",
            points: &pts,
        });
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>\n"));
        assert!(svg.contains("<polyline"));
        assert!(svg.contains("not plotted: s 2,0"));
    }
}
