//! Axis tick labels and the placement of point labels beside the points they name.

/// An axis tick label: at most 6 significant digits, no trailing zeros, no "-0" (so the
/// ticks read 10, 20, 0.25 rather than 10.0, 20.0, 0.250).
pub fn tick(v: f64) -> String {
    let s = crate::model::significant(v, 6);
    if s == "-0" { "0".into() } else { s }
}

/// A tick label on a logarithmic axis: the value where its mantissa is 1, 2 or 5 (plotters
/// puts a tick at every 1…9 × 10^k when an axis spans little more than a decade, and their
/// labels run into each other), else nothing.
pub fn log_tick(v: f64) -> String {
    if !(v > 0.0) {
        return String::new();
    }
    let m = v / 10f64.powf(v.log10().floor());
    if [1.0, 2.0, 5.0, 10.0]
        .iter()
        .any(|t| (m - t).abs() < 1e-6 * t)
    {
        crate::model::significant(v, 2)
    } else {
        String::new()
    }
}

/// Place a label of `w`×`h` pixels beside the point (px, py), inside `bounds` (left, top,
/// right, bottom: the plotting area) and overlapping no box in `placed`: the first free spot
/// of right, then left of the point, on its line, then one line up, one down, two up, …
/// (up to 12 lines away); where none is free, right of the point on its line. Records the box
/// and returns its top-left corner; a caller draws a leader line when the label left the
/// point's line ([`needs_leader`]).
pub fn place_label(
    placed: &mut Vec<(i32, i32, i32, i32)>,
    (px, py): (i32, i32),
    (w, h): (i32, i32),
    (bl, bt, br, bb): (i32, i32, i32, i32),
) -> (i32, i32) {
    let free = |l: i32, t: i32| {
        l >= bl
            && l + w <= br
            && t >= bt
            && t + h <= bb
            && !placed
                .iter()
                .any(|&(a, b, c, d)| l < c && l + w > a && t < d && t + h > b)
    };
    let base = py - h / 2;
    let spot = (0..25)
        .map(|k| if k % 2 == 1 { -(k + 1) / 2 } else { k / 2 })
        .flat_map(|line| [(px + 10, base + line * h), (px - 10 - w, base + line * h)])
        .find(|&(l, t)| free(l, t))
        .unwrap_or((
            (px + 10).min(br - w).max(bl),
            base.clamp(bt, (bb - h).max(bt)),
        ));
    placed.push((spot.0, spot.1, spot.0 + w, spot.1 + h));
    spot
}

/// Whether a label placed at `top` (height `h`) left the line of the point at `py`, so that
/// a leader line should join them.
pub fn needs_leader(py: i32, top: i32, h: i32) -> bool {
    (top + h / 2 - py).abs() > h / 2 + 1
}
