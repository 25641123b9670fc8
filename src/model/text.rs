//! Numbers as people read them: in tables, labels and error messages.

/// A number as a person reads it: 4 significant digits, in scientific notation (`3.554e7`)
/// when it is ≥ 1e5 or below 1e-3 in magnitude, never hundreds of digits.
pub fn readable(v: f64) -> String {
    if !v.is_finite() {
        return if v.is_nan() {
            "undefined".into()
        } else if v > 0.0 {
            "∞".into()
        } else {
            "−∞".into()
        };
    }
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.3e}");
        // 3.500e7 → 3.5e7
        match s.split_once('e') {
            Some((m, e)) if m.contains('.') => {
                format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
            }
            _ => s,
        }
    } else {
        short(v)
    }
}

/// A number as written back to the user in an error: every digit, in scientific form from 1e4
/// up (`1e300`, not 301 digits).
pub fn exact(x: f64) -> String {
    if x.abs() >= 1e4 {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// A number with at most 4 significant digits, without trailing zeros (for labels).
pub fn short(v: f64) -> String {
    significant(v, 4)
}

/// `v` with `digits` significant digits and no trailing zeros (0.3500 → 0.35, 10.0 → 10).
pub fn significant(v: f64, digits: i32) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let decimals = (digits - 1 - v.abs().log10().floor() as i32).clamp(0, 12) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}
