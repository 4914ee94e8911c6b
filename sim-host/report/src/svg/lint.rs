//! A layout check over the SVG this module writes: every `<text>` element's extent is
//! estimated (a character [`CHAR_WIDTH`] of the font size wide, a line `0.75` of it above
//! the baseline and `0.25` below, boxes shrunk by [`SLACK`]; rotated labels as the
//! axis-aligned box of the rotated line) and the labels that overlap each other or leave
//! the canvas are named. Slanted names are not compared with each other. A panel's data
//! (the paths, dots and bars in its clipped group) beyond its plotting area by more than
//! [`SLACK`] must come with a clipping mark (`class="clipped"`, [`super::Plot`] draws
//! one where each run leaves the axes).

/// Width of one character, in units of the font size.
pub const CHAR_WIDTH: f64 = 0.6;
/// Pixels trimmed off each side of a box before comparing (touching is not overlap).
pub const SLACK: f64 = 1.0;

/// The estimated extent of one label, in canvas px.
#[derive(Debug, Clone, PartialEq)]
pub struct TextBox {
    /// The label as written (XML entities left as they are).
    pub text: String,
    /// Left, top, right, bottom.
    pub rect: (f64, f64, f64, f64),
    /// Written at an angle other than 0 or -90 degrees.
    pub slanted: bool,
}

impl TextBox {
    fn overlaps(&self, o: &TextBox) -> bool {
        let (a, b) = (self.rect, o.rect);
        a.0 + SLACK < b.2 - SLACK
            && b.0 + SLACK < a.2 - SLACK
            && a.1 + SLACK < b.3 - SLACK
            && b.1 + SLACK < a.3 - SLACK
    }
}

fn attr(tag: &str, name: &str) -> Option<String> {
    let key = format!(" {name}=\"");
    let i = tag.find(&key)? + key.len();
    let rest = &tag[i..];
    Some(rest[..rest.find('"')?].to_string())
}

fn num(tag: &str, name: &str) -> Option<f64> {
    attr(tag, name)?.parse().ok()
}

/// `translate(x,y)` and the optional `rotate(a)` of a `transform` attribute.
fn transform(t: &str) -> Option<((f64, f64), f64)> {
    let i = t.find("translate(")? + "translate(".len();
    let inner = &t[i..i + t[i..].find(')')?];
    let mut it = inner.split([',', ' ']).filter(|s| !s.is_empty());
    let x: f64 = it.next()?.parse().ok()?;
    let y: f64 = it.next().and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let rot = t
        .find("rotate(")
        .and_then(|j| {
            let r = &t[j + "rotate(".len()..];
            r[..r.find(')')?].parse::<f64>().ok()
        })
        .unwrap_or(0.0);
    Some(((x, y), rot))
}

/// The canvas size and the estimated box of every non-empty label of `svg`.
pub fn text_boxes(svg: &str) -> ((f64, f64), Vec<TextBox>) {
    let mut canvas = (f64::INFINITY, f64::INFINITY);
    let mut groups: Vec<((f64, f64), Option<f64>)> = Vec::new();
    let mut out = Vec::new();
    for line in svg.lines() {
        let line = line.trim();
        if line.starts_with("<svg") {
            canvas = (
                num(line, "width").unwrap_or(f64::INFINITY),
                num(line, "height").unwrap_or(f64::INFINITY),
            );
        } else if line.starts_with("<g ") && !line.ends_with("/>") {
            let off = attr(line, "transform")
                .and_then(|t| transform(&t))
                .map_or((0.0, 0.0), |t| t.0);
            groups.push((off, num(line, "font-size")));
        } else if line.contains("<g ") || line.contains("<g>") {
            // A group opened after other elements on its line: no offset of its own.
            groups.push(((0.0, 0.0), None));
        }
        if line.starts_with("<text") {
            let (Some(open_end), Some(close)) = (line.find('>'), line.rfind("</text>")) else {
                continue;
            };
            let tag = &line[..open_end];
            let text = &line[open_end + 1..close];
            if text.trim().is_empty() {
                continue;
            }
            let (gx, gy) = groups
                .iter()
                .fold((0.0, 0.0), |a, g| (a.0 + g.0 .0, a.1 + g.0 .1));
            let fs = num(tag, "font-size")
                .or_else(|| groups.iter().rev().find_map(|g| g.1))
                .unwrap_or(11.0);
            let at = |k| num(tag, k).unwrap_or(0.0);
            let ((x, y), rot) = (attr(tag, "transform").and_then(|t| transform(&t)))
                .unwrap_or(((at("x"), at("y")), 0.0));
            // Entities count as one character.
            let chars = text.chars().count() - text.matches('&').count() * 3;
            let w = chars as f64 * CHAR_WIDTH * fs;
            let start = match attr(tag, "text-anchor").as_deref() {
                Some("middle") => -w / 2.0,
                Some("end") => -w,
                _ => 0.0,
            };
            // The line's corners in its own frame (along, across: baseline at 0, up < 0).
            let corners = [
                (start, -0.75 * fs),
                (start + w, -0.75 * fs),
                (start, 0.25 * fs),
                (start + w, 0.25 * fs),
            ];
            let (s, c) = rot.to_radians().sin_cos();
            let pts = corners.map(|(u, v)| (x + gx + u * c - v * s, y + gy + u * s + v * c));
            let inf = f64::INFINITY;
            let rect = (pts.iter()).fold((inf, inf, -inf, -inf), |r, p| {
                (r.0.min(p.0), r.1.min(p.1), r.2.max(p.0), r.3.max(p.1))
            });
            out.push(TextBox {
                text: text.to_string(),
                rect,
                slanted: rot != 0.0 && rot.rem_euclid(90.0) != 0.0,
            });
        }
        if line.starts_with("</g>") || line.ends_with("</g>") {
            groups.pop();
        }
    }
    (canvas, out)
}

/// The numbers of a path's `d` as `(x, y)` pairs (absolute `M`/`L` commands only).
fn path_points(d: &str) -> Vec<(f64, f64)> {
    let nums: Vec<f64> = d
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e'))
        .filter_map(|t| t.parse().ok())
        .collect();
    nums.chunks_exact(2).map(|p| (p[0], p[1])).collect()
}

/// Per panel of `svg` (by its title): the data points drawn beyond the plotting area
/// while the panel has no clipping mark. Empty: every panel holds its data or says not.
pub fn unmarked_clipping(svg: &str) -> Vec<String> {
    let mut out = Vec::new();
    let (mut area, mut title) = ([(0.0, 0.0); 2], String::new());
    let (mut inside, mut marked, mut beyond) = (false, false, 0usize);
    for line in svg.lines().map(str::trim) {
        let n = |k| num(line, k).unwrap_or(0.0);
        let corners = [
            (n("x"), n("y")),
            (n("x") + n("width"), n("y") + n("height")),
        ];
        if line.starts_with("<rect") && line.contains(r##"stroke="#333""##) {
            area = corners;
        } else if line.starts_with("<text") && line.contains(r#"font-weight="bold""#) {
            let t = &line[line.find('>').map_or(0, |i| i + 1)..];
            title = t.trim_end_matches("</text>").to_string();
        } else if line.contains(r#"<g clip-path=""#) {
            (inside, marked, beyond) = (true, false, 0);
        } else if inside && line.starts_with("</g>") {
            inside = false;
            if beyond > 0 && !marked {
                out.push(format!(
                    "panel `{title}`: {beyond} data points beyond its axes, no clipping mark"
                ));
            }
        } else if inside {
            marked |= line.contains(r#"class="clipped""#);
            let pts = match line.split(' ').next() {
                _ if marked => Vec::new(),
                Some("<path") => {
                    let p = path_points(&attr(line, "d").unwrap_or_default());
                    // A cross mark (two strokes): its centre.
                    match (line.matches('M').count(), p.as_slice()) {
                        (2, [a, b, _, _]) => vec![((a.0 + b.0) / 2.0, (a.1 + b.1) / 2.0)],
                        _ => p,
                    }
                }
                Some("<circle") => vec![(n("cx"), n("cy"))],
                Some("<rect") => corners.to_vec(),
                _ => Vec::new(),
            };
            let [(l, t), (r, b)] = area;
            let out_of = |p: &&(f64, f64)| {
                p.0 < l - SLACK || p.0 > r + SLACK || p.1 < t - SLACK || p.1 > b + SLACK
            };
            beyond += pts.iter().filter(out_of).count();
        }
    }
    out
}

/// The layout problems of `svg`: each pair of labels that overlap, each label that
/// leaves the canvas, and each panel whose data leaves its axes unmarked
/// ([`unmarked_clipping`]), as a sentence naming them. Empty: none.
pub fn problems(svg: &str) -> Vec<String> {
    let ((w, h), boxes) = text_boxes(svg);
    let mut out = unmarked_clipping(svg);
    for (i, a) in boxes.iter().enumerate() {
        let r = a.rect;
        if r.0 < -SLACK || r.1 < -SLACK || r.2 > w + SLACK || r.3 > h + SLACK {
            out.push(format!(
                "`{}` leaves the {w} x {h} canvas ({:.0}, {:.0}, {:.0}, {:.0})",
                a.text, r.0, r.1, r.2, r.3
            ));
        }
        for b in &boxes[i + 1..] {
            if !(a.slanted && b.slanted) && a.overlaps(b) {
                out.push(format!("`{}` overlaps `{}`", a.text, b.text));
            }
        }
    }
    out
}
