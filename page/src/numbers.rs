//! Numbers as people read them, in tables, reports and warnings alike, and the
//! headers of their columns.

/// A number with four significant digits, in scientific notation when it is very
/// small or large; `–` for NaN.
pub fn number(v: f64) -> String {
    if v.is_nan() {
        return "–".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    if !v.is_finite() {
        return if v > 0.0 {
            "∞".into()
        } else {
            "−∞".into()
        };
    }
    let magnitude = v.abs().log10().floor() as i32;
    if !(-3..5).contains(&magnitude) {
        return format!("{v:.3e}");
    }
    let decimals = (3 - magnitude).max(0) as usize;
    let text = format!("{v:.decimals$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

/// `name [unit]`, or `name` alone when the unit is unknown or empty.
pub fn header(name: &str, unit: Option<&str>) -> String {
    match unit {
        Some(unit) if !unit.is_empty() => format!("{name} [{unit}]"),
        _ => name.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_carry_units_only_when_there_is_one() {
        assert_eq!(header("outlet_diameter", Some("m")), "outlet_diameter [m]");
        assert_eq!(header("count", Some("")), "count");
        assert_eq!(header("other", None), "other");
    }
}
