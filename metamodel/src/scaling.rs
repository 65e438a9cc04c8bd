//! Conversion between natural units and coded `[-1, 1]` units.

/// The range of one factor in natural units, used to map coded values onto it.
///
/// Coded `-1` is `min`, coded `+1` is `max`, coded `0` is the centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FactorRange {
    /// Lower bound in natural units.
    pub min: f64,
    /// Upper bound in natural units; greater than `min`.
    pub max: f64,
}

impl FactorRange {
    /// Natural value of a coded value.
    pub fn to_natural(&self, coded: f64) -> f64 {
        let centre = 0.5 * (self.min + self.max);
        let half_width = 0.5 * (self.max - self.min);
        centre + half_width * coded
    }

    /// Coded value of a natural value.
    pub fn to_coded(&self, natural: f64) -> f64 {
        let centre = 0.5 * (self.min + self.max);
        let half_width = 0.5 * (self.max - self.min);
        (natural - centre) / half_width
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn ends_and_centre_map_onto_bounds() {
        let range = FactorRange {
            min: 20.0,
            max: 50.0,
        };
        assert_eq!(range.to_natural(-1.0), 20.0);
        assert_eq!(range.to_natural(1.0), 50.0);
        assert_eq!(range.to_natural(0.0), 35.0);
    }

    proptest! {
        #[test]
        fn coded_natural_round_trip(min in -1e3f64..1e3, width in 1e-6f64..1e3, coded in -1.0f64..1.0) {
            let range = FactorRange { min, max: min + width };
            let back = range.to_coded(range.to_natural(coded));
            prop_assert!((back - coded).abs() < 1e-6);
        }
    }
}
