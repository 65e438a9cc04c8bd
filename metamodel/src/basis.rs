//! Polynomial bases over coded factors: complete polynomials of a given order, as
//! monomials (`a`, `a*f`, `a^2`) or products of Legendre polynomials (`P1(a)`,
//! `P2(a)`, `P1(a)*P1(f)`). Both span the same space, so fits in either predict the
//! same; Legendre columns are better conditioned on `[-1, 1]`.

use crate::levels::{is_text, level_of};

/// Which one-dimensional polynomials the terms are products of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BasisKind {
    /// Powers `x^k`.
    Monomial,
    /// Legendre polynomials `P_k(x)`, orthogonal on `[-1, 1]`.
    Legendre,
}

/// A polynomial basis in `n_factors` variables: a list of terms, each a product of
/// one-dimensional polynomials. [`Basis::complete`] gives every term up to a total degree;
/// [`Basis::from_terms`] any subset, such as what [`crate::prune::prune`] leaves.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Basis {
    /// Kind of the one-dimensional factors.
    pub kind: BasisKind,
    /// Highest total degree among the terms (for a complete basis, the degree asked for).
    pub order: u32,
    /// Number of variables.
    pub n_factors: usize,
    /// Degree of each variable in each term; the first term is the constant. For a
    /// text factor (see `levels`) the "degree" `e > 0` names its level `e` (0-based):
    /// the term is 1 at that level and 0 at the others (level 0 is the reference).
    pub terms: Vec<Vec<u32>>,
    /// Levels of each factor, 0 for a numeric one ([`crate::levels`]); empty when
    /// every factor is numeric.
    pub levels: Vec<u32>,
}

impl Basis {
    /// Every term of total degree at most `order`, constant first, then by degree;
    /// within a degree, pure powers before interactions, in factor order.
    pub fn complete(kind: BasisKind, n_factors: usize, order: u32) -> Basis {
        Basis::complete_with_levels(kind, n_factors, &[], order)
    }

    /// [`Basis::complete`] over numeric and text factors (`levels`, see
    /// [`crate::levels`]): a text factor of `L` levels enters as `L − 1` indicator
    /// terms of degree one each, so a quadratic basis has each indicator alone, times
    /// each numeric factor and times each other text factor's indicators, but no
    /// squares of indicators (an indicator squared is itself).
    pub fn complete_with_levels(
        kind: BasisKind,
        n_factors: usize,
        levels: &[u32],
        order: u32,
    ) -> Basis {
        let mut terms = Vec::new();
        for degree in 0..=order {
            let mut of_degree = Vec::new();
            exponents(
                levels,
                n_factors,
                degree,
                &mut vec![0; n_factors],
                0,
                &mut of_degree,
            );
            // Pure powers (one variable) first, then interactions; stable within.
            // A text factor's indicators in level order.
            of_degree.sort_by_key(|t: &Vec<u32>| {
                let key: Vec<u32> = t
                    .iter()
                    .enumerate()
                    .map(|(j, &e)| match is_text(levels, j) && e > 0 {
                        true => levels[j] - e,
                        false => e,
                    })
                    .collect();
                (t.iter().filter(|&&e| e > 0).count(), std::cmp::Reverse(key))
            });
            terms.extend(of_degree);
        }
        Basis {
            kind,
            order,
            n_factors,
            terms,
            levels: levels.to_vec(),
        }
    }

    /// A basis of exactly `terms` (exponent vectors of length `n_factors`, kept in the
    /// given order), whose `order` is their highest total degree. Used for reduced models:
    /// the names and rows follow the terms, whatever is missing.
    pub fn from_terms(kind: BasisKind, n_factors: usize, terms: Vec<Vec<u32>>) -> Basis {
        Basis::from_terms_with_levels(kind, n_factors, &[], terms)
    }

    /// [`Basis::from_terms`] over numeric and text factors (`levels`).
    pub fn from_terms_with_levels(
        kind: BasisKind,
        n_factors: usize,
        levels: &[u32],
        terms: Vec<Vec<u32>>,
    ) -> Basis {
        let order = terms.iter().map(|t| degree(levels, t)).max().unwrap_or(0);
        Basis {
            kind,
            order,
            n_factors,
            terms,
            levels: levels.to_vec(),
        }
    }

    /// True when term `outer` contains term `inner`: a different term that has every
    /// numeric factor to at least `inner`'s degree and every text indicator `inner`
    /// has. Pruning keeps a term while a term containing it stays.
    pub fn contains(&self, outer: &[u32], inner: &[u32]) -> bool {
        outer != inner
            && outer.iter().zip(inner).enumerate().all(|(j, (o, i))| {
                if is_text(&self.levels, j) {
                    *i == 0 || o == i
                } else {
                    o >= i
                }
            })
    }

    /// Number of terms.
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// True for a basis without terms (never for a complete basis).
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// The terms' names, with `factors` naming the variables.
    pub fn names(&self, factors: &[String]) -> Vec<String> {
        self.terms
            .iter()
            .map(|t| self.term_name(t, factors))
            .collect()
    }

    fn term_name(&self, term: &[u32], factors: &[String]) -> String {
        let parts: Vec<String> = term
            .iter()
            .zip(factors)
            .enumerate()
            .filter(|(_, (e, _))| **e > 0)
            .map(|(j, (&e, name))| match (self.kind, e) {
                _ if is_text(&self.levels, j) => format!("{name}[{}]", e + 1),
                (BasisKind::Monomial, 1) => name.clone(),
                (BasisKind::Monomial, e) => format!("{name}^{e}"),
                (BasisKind::Legendre, e) => format!("P{e}({name})"),
            })
            .collect();
        if parts.is_empty() {
            "1".to_string()
        } else {
            parts.join("*")
        }
    }

    /// Values of every term at the coded point `x`.
    pub fn row(&self, x: &[f64]) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.terms.len());
        self.row_into(x, &mut out);
        out
    }

    /// Values of every term at `x`, written into `out` (cleared first).
    pub fn row_into(&self, x: &[f64], out: &mut Vec<f64>) {
        out.clear();
        let max = self.order as usize;
        // One-dimensional values p[j][k] = P_k(x_j) or x_j^k.
        let mut table = [[0.0f64; 8]; 16];
        let use_table = max < 8 && x.len() <= 16;
        if use_table {
            for (row, &xj) in table.iter_mut().zip(x) {
                for (k, value) in row.iter_mut().enumerate().take(max + 1) {
                    *value = self.one_dimensional(k as u32, xj);
                }
            }
        }
        for term in &self.terms {
            let mut value = 1.0;
            for (j, &e) in term.iter().enumerate() {
                if e > 0 && is_text(&self.levels, j) {
                    if level_of(x[j], self.levels[j]) != e {
                        value = 0.0;
                    }
                } else if e > 0 {
                    value *= if use_table {
                        table[j][e as usize]
                    } else {
                        self.one_dimensional(e, x[j])
                    };
                }
            }
            out.push(value);
        }
    }

    fn one_dimensional(&self, degree: u32, x: f64) -> f64 {
        match self.kind {
            BasisKind::Monomial => x.powi(degree as i32),
            BasisKind::Legendre => legendre(degree, x),
        }
    }
}

/// The Legendre polynomial `P_n(x)` by Bonnet's recurrence.
pub fn legendre(n: u32, x: f64) -> f64 {
    let (mut previous, mut current) = (1.0, x);
    if n == 0 {
        return 1.0;
    }
    for k in 1..n {
        let k = k as f64;
        let next = ((2.0 * k + 1.0) * x * current - k * previous) / (k + 1.0);
        previous = current;
        current = next;
    }
    current
}

/// A term's total degree: its numeric exponents plus one per text indicator.
fn degree(levels: &[u32], term: &[u32]) -> u32 {
    term.iter()
        .enumerate()
        .map(|(j, &e)| {
            if is_text(levels, j) {
                u32::from(e > 0)
            } else {
                e
            }
        })
        .sum()
}

/// All exponent vectors of `n` variables of total [`degree`] `degree`; a text factor
/// of `L` levels takes 0 or one of its indicators 1..L−1.
fn exponents(
    levels: &[u32],
    n: usize,
    degree_wanted: u32,
    current: &mut Vec<u32>,
    index: usize,
    out: &mut Vec<Vec<u32>>,
) {
    if index == n {
        if degree(levels, current) == degree_wanted {
            out.push(current.clone());
        }
        return;
    }
    let used = degree(levels, &current[..index]);
    let choices: Vec<u32> = if is_text(levels, index) {
        if used < degree_wanted {
            (0..levels[index]).collect()
        } else {
            vec![0]
        }
    } else {
        (0..=(degree_wanted - used)).collect()
    };
    for e in choices {
        current[index] = e;
        exponents(levels, n, degree_wanted, current, index + 1, out);
    }
    current[index] = 0;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(kind: BasisKind, order: u32) -> Vec<String> {
        Basis::complete(kind, 2, order).names(&["a".into(), "f".into()])
    }

    #[test]
    fn quadratic_terms_are_named_in_the_usual_order() {
        assert_eq!(
            names(BasisKind::Monomial, 2),
            ["1", "a", "f", "a^2", "f^2", "a*f"]
        );
        assert_eq!(
            names(BasisKind::Legendre, 2),
            ["1", "P1(a)", "P1(f)", "P2(a)", "P2(f)", "P1(a)*P1(f)"]
        );
    }

    #[test]
    fn a_text_factor_enters_as_indicators_of_degree_one() {
        // a numeric, m text with 3 levels (0 is the reference).
        let basis = Basis::complete_with_levels(BasisKind::Legendre, 2, &[0, 3], 2);
        let names = basis.names(&["a".into(), "m".into()]);
        assert_eq!(
            names,
            [
                "1",
                "P1(a)",
                "m[2]",
                "m[3]",
                "P2(a)",
                "P1(a)*m[2]",
                "P1(a)*m[3]"
            ]
        );
        assert_eq!(basis.order, 2);
        // At level 3 (coded 1) only m[3] is on; at level 1 (coded −1) neither.
        let row = basis.row(&[0.5, 1.0]);
        assert_eq!(&row[2..4], &[0.0, 1.0]);
        assert_eq!(row[6], 0.5);
        let row = basis.row(&[0.5, -1.0]);
        assert_eq!(&row[2..4], &[0.0, 0.0]);
        assert_eq!(&row[5..], &[0.0, 0.0]);
        // Two text factors of two levels: one indicator each and their product.
        let two = Basis::complete_with_levels(BasisKind::Monomial, 2, &[2, 2], 2);
        assert_eq!(
            two.names(&["p".into(), "q".into()]),
            ["1", "p[2]", "q[2]", "p[2]*q[2]"]
        );
    }

    #[test]
    fn complete_bases_have_binomial_sizes() {
        // C(k + d, d) terms for k factors and order d.
        assert_eq!(Basis::complete(BasisKind::Monomial, 4, 2).len(), 15);
        assert_eq!(Basis::complete(BasisKind::Legendre, 3, 3).len(), 20);
        assert_eq!(Basis::complete(BasisKind::Monomial, 3, 1).len(), 4);
    }

    #[test]
    fn an_incomplete_term_list_names_and_evaluates_its_own_terms() {
        let full = Basis::complete(BasisKind::Legendre, 3, 2);
        // Keep 1, a, c, a^2, a*c.
        let kept: Vec<Vec<u32>> = full
            .terms
            .iter()
            .filter(|t| t[1] == 0 && t[2] < 2)
            .cloned()
            .collect();
        let reduced = Basis::from_terms(BasisKind::Legendre, 3, kept);
        assert_eq!(reduced.order, 2);
        let factors = ["a".to_string(), "b".to_string(), "c".to_string()];
        assert_eq!(
            reduced.names(&factors),
            ["1", "P1(a)", "P1(c)", "P2(a)", "P1(a)*P1(c)"]
        );
        let point = [0.3, -0.7, 0.9];
        let full_row = full.row(&point);
        let full_names = full.names(&factors);
        for (name, value) in reduced.names(&factors).iter().zip(reduced.row(&point)) {
            let index = full_names.iter().position(|n| n == name).unwrap();
            assert_eq!(value, full_row[index], "{name}");
        }
        // Without its second-degree terms the order drops to one.
        let linear = Basis::from_terms(BasisKind::Monomial, 3, full.terms[..4].to_vec());
        assert_eq!(linear.order, 1);
        assert_eq!(linear.row(&point), [1.0, 0.3, -0.7, 0.9]);
        // A high power alone is still evaluated exactly.
        let cube = Basis::from_terms(BasisKind::Monomial, 2, vec![vec![0, 0], vec![0, 9]]);
        assert_eq!(cube.order, 9);
        assert!((cube.row(&[0.0, 0.5])[1] - 0.5f64.powi(9)).abs() < 1e-15);
    }

    #[test]
    fn legendre_polynomials_match_closed_forms() {
        for x in [-1.0, -0.3, 0.0, 0.5, 1.0] {
            assert!((legendre(2, x) - (3.0 * x * x - 1.0) / 2.0).abs() < 1e-15);
            assert!((legendre(3, x) - (5.0 * x * x * x - 3.0 * x) / 2.0).abs() < 1e-15);
        }
    }
}
