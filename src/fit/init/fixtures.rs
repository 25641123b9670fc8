//! Rows shared by the initialisation's unit tests.

use crate::fit::problem::Rows;

/// `m` rows of a basis s (0 to 3), data f (0.1 to 1.1) and weights w (1 to 1/5), smooth
/// and deterministic, for the sums' tests.
pub(super) fn test_rows(m: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let s = (0..m)
        .map(|i| (0.37 * i as f64).sin().abs() * 3.0)
        .collect();
    let fd = (0..m)
        .map(|i| 0.1 + (0.11 * i as f64).cos().powi(2))
        .collect();
    let w = (0..m).map(|i| 1.0 / (1.0 + i as f64 % 5.0)).collect();
    (s, fd, w)
}

/// Visible rows spread over the hemisphere, incidence and azimuth varied (in and out of
/// the plane of incidence).
pub(super) fn spread_rows() -> Rows {
    use crate::fit::problem::Row;
    use crate::model::Geometry;
    let mut rows = Vec::new();
    for k in 0..300 {
        let x = k as f64;
        let g = Geometry::from_angles(
            (0.37 * x).sin().abs() * 1.4,
            0.0,
            (0.71 * x).cos().abs() * 1.4,
            2.0 * (0.13 * x).sin() * std::f64::consts::PI,
        );
        if g.visible() {
            rows.push(Row {
                g,
                cos_i: g.nl,
                target: 0.0,
                sw: 1.0,
            });
        }
    }
    Rows::from(rows)
}
