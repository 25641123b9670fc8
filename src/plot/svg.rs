//! SVG text as glyph outlines: every `<text>` plotters writes becomes a `<path>` of the
//! embedded font, so an SVG looks the same on every machine.

use crate::support::png::FONT;

/// Replace every `<text>` element plotters writes with a `<path>` of the embedded font's
/// glyph outlines, so an SVG looks the same on every machine without the font installed.
/// Handles what plotters emits: `x`, `y`, `dy` in em or ex, `text-anchor`, `font-size`,
/// `fill`, `opacity` and `transform`.
pub fn svg_text_to_paths(svg: &str) -> String {
    use ab_glyph::{Font, FontRef, OutlineCurve};
    let Ok(font) = FontRef::try_from_slice(FONT) else {
        return svg.to_string();
    };
    let upem = font.units_per_em().unwrap_or(2048.0);
    let attr = |tag: &str, name: &str| -> Option<String> {
        let key = format!(" {name}=\"");
        let i = tag.find(&key)? + key.len();
        Some(tag[i..i + tag[i..].find('"')?].to_string())
    };
    let mut out = String::with_capacity(svg.len());
    let mut rest = svg;
    while let Some(i) = rest.find("<text") {
        out.push_str(&rest[..i]);
        let Some(open_end) = rest[i..].find('>').map(|e| i + e + 1) else {
            break;
        };
        let Some(close) = rest[open_end..].find("</text>").map(|e| open_end + e) else {
            break;
        };
        let tag = &rest[i..open_end];
        let content = rest[open_end..close]
            .trim()
            .replace("&lt;", "<")
            .replace("&gt;", ">")
            .replace("&quot;", "\"")
            .replace("&apos;", "'")
            .replace("&amp;", "&");
        rest = &rest[close + "</text>".len()..];
        let num = |n: &str, d: f32| {
            attr(tag, n)
                .and_then(|v| v.parse::<f32>().ok())
                .unwrap_or(d)
        };
        let size = num("font-size", 12.0);
        let k = size / upem;
        let dy = attr(tag, "dy").map_or(0.0, |v| {
            if let Some(e) = v.strip_suffix("em") {
                e.parse::<f32>().unwrap_or(0.0) * size
            } else if let Some(e) = v.strip_suffix("ex") {
                // DejaVu Sans' x-height is 0.545 em.
                e.parse::<f32>().unwrap_or(0.0) * 0.545 * size
            } else {
                v.parse().unwrap_or(0.0)
            }
        });
        let ids: Vec<_> = content.chars().map(|c| font.glyph_id(c)).collect();
        let mut advance = Vec::with_capacity(ids.len());
        let mut pen = 0.0;
        for (j, &id) in ids.iter().enumerate() {
            if j > 0 {
                pen += font.kern_unscaled(ids[j - 1], id);
            }
            advance.push(pen);
            pen += font.h_advance_unscaled(id);
        }
        let width = pen * k;
        let x0 = num("x", 0.0)
            - match attr(tag, "text-anchor").as_deref() {
                Some("middle") => width / 2.0,
                Some("end") => width,
                _ => 0.0,
            };
        let base = num("y", 0.0) + dy;
        let mut d = String::new();
        let pt = |p: ab_glyph::Point, ox: f32| (x0 + (ox + p.x) * k, base - p.y * k);
        let mut last = None;
        for (j, &id) in ids.iter().enumerate() {
            let Some(outline) = font.outline(id) else {
                continue;
            };
            let ox = advance[j];
            for c in &outline.curves {
                let (start, seg) = match c {
                    OutlineCurve::Line(a, b) => {
                        let (bx, by) = pt(*b, ox);
                        (*a, format!("L{bx:.2} {by:.2}"))
                    }
                    OutlineCurve::Quad(a, b, c) => {
                        let ((bx, by), (cx, cy)) = (pt(*b, ox), pt(*c, ox));
                        (*a, format!("Q{bx:.2} {by:.2} {cx:.2} {cy:.2}"))
                    }
                    OutlineCurve::Cubic(a, b, c, e) => {
                        let ((bx, by), (cx, cy), (ex, ey)) = (pt(*b, ox), pt(*c, ox), pt(*e, ox));
                        (
                            *a,
                            format!("C{bx:.2} {by:.2} {cx:.2} {cy:.2} {ex:.2} {ey:.2}"),
                        )
                    }
                };
                let s = pt(start, ox);
                if last != Some((j, start.x.to_bits(), start.y.to_bits())) {
                    d.push_str(&format!("M{:.2} {:.2}", s.0, s.1));
                }
                d.push_str(&seg);
                let end = match c {
                    OutlineCurve::Line(_, b) => *b,
                    OutlineCurve::Quad(_, _, c) => *c,
                    OutlineCurve::Cubic(_, _, _, e) => *e,
                };
                last = Some((j, end.x.to_bits(), end.y.to_bits()));
            }
        }
        let fill = attr(tag, "fill").unwrap_or_else(|| "#000000".into());
        let opacity = attr(tag, "opacity").unwrap_or_else(|| "1".into());
        let transform = attr(tag, "transform")
            .map(|t| format!(" transform=\"{t}\""))
            .unwrap_or_default();
        out.push_str(&format!(
            "<path d=\"{d}\" fill=\"{fill}\" opacity=\"{opacity}\"{transform}><title>{}</title></path>",
            content.replace('&', "&amp;").replace('<', "&lt;")
        ));
    }
    out.push_str(rest);
    out
}
