//! The plots' ticks, labels, legend, escaping and histograms.

use super::ticks::{fmt_log, log_ticks};
use super::*;

/// A panel alone as an SVG document.
trait ToSvg {
    fn to_svg(&self) -> String;
}

impl ToSvg for Plot {
    fn to_svg(&self) -> String {
        Figure::new("").panel(self.clone()).to_svg()
    }
}

#[test]
fn ticks_cover_range_with_nice_steps() {
    let t = nice_ticks(0.0, 20.0, 7);
    assert_eq!(t.first(), Some(&0.0));
    assert_eq!(t.last(), Some(&20.0));
    let t = nice_ticks(-0.37, 1.2, 6);
    assert!(t.iter().all(|v| *v >= -0.37 && *v <= 1.2));
    assert!(t.len() >= 3 && t.len() <= 9, "{t:?}");
}

#[test]
fn tick_labels_are_exact() {
    let t = nice_ticks(0.0, 1.2, 5); // step 0.25
    let labels: Vec<String> = t.iter().map(|v| fmt_tick(*v, &t)).collect();
    assert_eq!(labels, ["0", "0.25", "0.50", "0.75", "1.00"]);
    let t = nice_ticks(0.0, 3e6, 3);
    assert_eq!(fmt_tick(t[1], &t), "1e6");
    let t = nice_ticks(1.0, 10.0, 4); // step 2.5
    assert_eq!(fmt_tick(2.5, &t), "2.5");
}

#[test]
fn svg_contains_series_legend_and_escapes() {
    let p = Plot::new("a<b")
        .series(Series::line("y & z", vec![(0.0, 1.0), (1.0, 2.0)]))
        .series(Series::scatter("pts", vec![(0.5, 1.5), (f64::NAN, 0.0)]));
    let s = p.to_svg();
    assert!(s.contains("a&lt;b"));
    assert!(s.contains("y &amp; z"));
    assert_eq!(s.matches("<circle").count(), 2); // one point + one legend marker
    assert!(s.trim_end().ends_with("</svg>"));
}

#[test]
fn histogram_has_one_rect_per_bin() {
    let p = Plot::histogram("h", &[0.0, 1.0, 2.0, 3.0], &[1.0, 4.0, 2.0]);
    let s = p.to_svg();
    assert_eq!(s.matches("fill=\"#56B4E9\"").count(), 3);
}

#[test]
fn categories_replace_the_numeric_x_ticks_and_a_note_is_written() {
    let names = ["yaw_lead.x".to_string(), "traction_pi.e".to_string()];
    let p = Plot::histogram("h", &[0.0, 1.0, 2.0], &[1.0, 2.0])
        .x_categories(&names)
        .note("not measured");
    let s = p.to_svg();
    assert!(s.contains(">yaw_lead.x</text>"), "{s}");
    assert!(s.contains(">traction_pi.e</text>"), "{s}");
    assert_eq!(s.matches("rotate(-40)").count(), 2);
    // No numeric x tick label (the tick labels are the names).
    let numeric_x = s
        .split("text-anchor=\"middle\">")
        .skip(1)
        .filter_map(|t| t.split('<').next())
        .filter(|t| t.parse::<f64>().is_ok())
        .count();
    assert_eq!(numeric_x, 0, "{s}");
    assert!(s.contains(">not measured</text>"), "{s}");
}

#[test]
fn log_axes_have_value_labels_and_skip_non_positive_points() {
    // Four decades: the decades, labelled with the values.
    let p = Plot::new("log").log_x().log_y().series(Series::line(
        "s",
        vec![(0.1, 1.0), (1.0, 10.0), (0.0, 5.0), (1000.0, 100.0)],
    ));
    let s = p.to_svg();
    for l in [">0.1<", ">1<", ">10<", ">100<", ">1000<"] {
        assert!(s.contains(l), "{l}: {s}");
    }
    assert!(!s.contains(">-1<") && !s.contains("NaN"), "{s}");
    // Under three decades: 1, 2, 5 times them.
    let t = log_ticks(0.0, 1.0);
    let v: Vec<f64> = t
        .iter()
        .map(|t| (10f64.powf(*t) * 1e6).round() / 1e6)
        .collect();
    assert_eq!(v, [1.0, 2.0, 5.0, 10.0]);
    assert_eq!(fmt_log(2e6), "2e6");
    assert_eq!(fmt_log(0.05), "0.05");
}

#[test]
fn marks_are_drawn_labelled_and_inside_the_range() {
    // A threshold far above the data is still on the axis, with its label.
    let p = Plot::new("m")
        .series(Series::line("s", vec![(0.0, 0.0), (1.0, 1.0)]))
        .hmark(50.0, "threshold 50", "#D55E00")
        .vmark(3.0, "event", "#000");
    let s = p.to_svg();
    assert!(s.contains(">threshold 50</text>"), "{s}");
    assert!(s.contains(">event</text>"), "{s}");
    let ((x0, x1), (y0, y1)) = p.data_range();
    assert!(x0 <= 0.0 && x1 >= 3.0 && y0 <= 0.0 && y1 >= 50.0);
}

#[test]
fn a_panel_with_only_a_note_has_no_axes() {
    let s = Plot::new("Execution time")
        .x_label("exec (us)")
        .note("not measured in process")
        .to_svg();
    assert!(s.contains(">not measured in process</text>"));
    assert!(!s.contains(">exec (us)</text>"), "{s}");
    assert!(
        !s.contains(">0.2</text>") && !s.contains(">0</text>"),
        "{s}"
    );
}

#[test]
fn a_long_first_category_name_is_not_cut_off() {
    let names = [
        "a rather long first category name".to_string(),
        "b".to_string(),
    ];
    let s = Plot::histogram("h", &[0.0, 1.0, 2.0], &[1.0, 2.0])
        .x_categories(&names)
        .to_svg();
    // The name's left end: its anchor x minus its length at 6.6 px x cos(40).
    let anchor: f64 = s
        .split("<text transform=\"translate(")
        .nth(1)
        .and_then(|t| t.split(',').next())
        .and_then(|x| x.parse().ok())
        .unwrap();
    assert!(
        anchor - names[0].len() as f64 * 6.6 * 0.766 >= 0.0,
        "{anchor}"
    );
}

#[test]
fn data_beyond_a_fixed_range_is_marked_on_the_edge_and_in_the_legend() {
    let pts = vec![(0.0, 0.0), (1.0, 2.0), (2.0, 0.5), (3.0, -3.0), (4.0, 0.0)];
    let held = Plot::new("all in").series(Series::line("s", pts.clone()));
    let s = held.to_svg();
    assert!(
        !s.contains("class=\"clipped\"") && !s.contains("beyond the axes"),
        "{s}"
    );
    let clipped = held.clone().y_range(-1.0, 1.0);
    let s = clipped.to_svg();
    // Two runs leave the range: one above, one below.
    assert_eq!(s.matches("class=\"clipped\"").count(), 2, "{s}");
    assert!(s.contains(">s: beyond the axes</text>"), "{s}");
    // The lint accepts data beyond the axes with its marks, not without them.
    assert!(lint::unmarked_clipping(&held.to_svg()).is_empty());
    assert!(lint::unmarked_clipping(&s).is_empty(), "{s}");
    let strip = |svg: &str| -> String {
        svg.lines()
            .filter(|l| !l.contains("clipped"))
            .map(|l| format!("{l}\n"))
            .collect()
    };
    assert_eq!(lint::unmarked_clipping(&strip(&s)).len(), 1, "{s}");
    let dots = Plot::new("dots")
        .x_range(0.0, 1.0)
        .series(Series::scatter("d", vec![(0.5, 0.0), (3.0, 0.0)]))
        .to_svg();
    assert!(lint::problems(&dots).is_empty(), "{dots}");
    let p = lint::problems(&strip(&dots));
    assert!(p[0].contains("panel `dots`: 1 data points"), "{p:?}");
    // A log axis's floor clips what lies under it.
    let s = Plot::new("log")
        .log_y()
        .y_range(1.0, 100.0)
        .series(Series::line("ms", vec![(0.0, 0.01), (1.0, 10.0)]))
        .to_svg();
    assert_eq!(s.matches("class=\"clipped\"").count(), 1, "{s}");
}

#[test]
fn the_lint_finds_overlapping_and_cut_off_labels() {
    let two = |x2: f64| {
        format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"200\" height=\"100\">\n\
             <g transform=\"translate(0,20)\" font-size=\"11\">\n\
             <text x=\"10\" y=\"20\">first label</text>\n\
             <text x=\"{x2}\" y=\"24\">second</text>\n</g>\n</svg>\n"
        )
    };
    // "first label": 11 characters x 6.6 px = 72.6 px from x = 10.
    assert_eq!(
        lint::problems(&two(60.0)).len(),
        1,
        "{:?}",
        lint::problems(&two(60.0))
    );
    assert!(lint::problems(&two(90.0)).is_empty());
    // Past the right edge of the 200 px canvas.
    assert_eq!(lint::problems(&two(180.0)).len(), 1);
    let ((w, h), boxes) = lint::text_boxes(&two(90.0));
    assert_eq!((w, h), (200.0, 100.0));
    // The group's offset is applied: the baseline at 20 + 20, the box above it.
    assert!(
        (boxes[0].rect.3 - (40.0 + 0.25 * 11.0)).abs() < 1e-9,
        "{boxes:?}"
    );
}

#[test]
fn mark_labels_at_the_same_place_do_not_overprint() {
    let p = Plot::new("marks")
        .series(Series::line(
            "y",
            (0..100).map(|i| (i as f64 * 0.1, 1.0)).collect(),
        ))
        .hmark(1.0, "allowed ±1", "#009E73")
        .hmark(1.05, "fail above ±1.05", "#D55E00")
        .hmark(-1.0, "", "#009E73")
        .vmark(6.0, "plant fault 6.000 s", "#000")
        .vmark(6.02, "hunting alarm 6.020 s", "#D55E00")
        .vmark(6.05, "deadline 6.050 s", "#777");
    let s = Figure::new("marks").panel(p).to_svg();
    assert!(lint::problems(&s).is_empty(), "{:?}", lint::problems(&s));
}
