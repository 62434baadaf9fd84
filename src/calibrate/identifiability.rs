//! Which parameter combinations the training tests can pin down (paper Sec. 3.4, Table 1).
//!
//! The scaled Jacobian S_ij = ∂ ln y_i / ∂ ln θ_j of the training predictions says how a relative
//! change of each parameter moves each prediction. Its singular value decomposition splits
//! log-parameter space into directions the data see (large singular values) and directions they
//! do not (singular values ≈ 0). A direction v the data see is the combination Π θ_j^{v_j}: for
//! the Euler cantilever every row is (−1, 3) in (E, L), so only L³/E is identifiable.

use nalgebra::{DMatrix, DVector};

use super::{Problem, optimize};

/// Singular values below this fraction of the largest count as zero: the data cannot see them.
const RANK_TOLERANCE: f64 = 1e-6;
/// Singular values below this fraction are seen, but so faintly that noise will swamp them.
const WEAK_TOLERANCE: f64 = 1e-3;

#[derive(Debug, Clone, PartialEq)]
pub struct Identifiability {
    pub identifiable: bool,
    /// Plain-language verdict.
    pub note: String,
    /// Singular values of the scaled Jacobian, largest first.
    pub singular_values: Vec<f64>,
    /// The combinations the data do determine, such as `L^3/E`, when not every parameter is.
    pub combinations: Vec<String>,
}

/// Analyses the problem's training predictions around `theta` (typically the least-squares estimate).
pub fn analyse(problem: &Problem, names: &[String], theta: &DVector<f64>) -> Identifiability {
    let jacobian = scaled_jacobian(problem, theta);
    let svd = jacobian.clone().svd(false, true);
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let values: Vec<f64> = order.iter().map(|&k| svd.singular_values[k]).collect();
    let largest = values.first().copied().unwrap_or(0.0);
    let p = names.len();
    // With fewer tests than parameters the SVD has fewer than p values: the rest are zero.
    let seen = values
        .iter()
        .filter(|&&s| s > RANK_TOLERANCE * largest && largest > 0.0)
        .count();
    let v_t = svd.v_t.expect("requested V");
    let combinations: Vec<String> = order[..seen]
        .iter()
        .map(|&k| combination(names, v_t.row(k).transpose().as_slice()))
        .collect();

    if seen == p {
        let weakest = values[p - 1] / largest;
        let note = if weakest < WEAK_TOLERANCE {
            format!(
                "all {p} parameters are identifiable in principle, but weakly: the weakest direction is \
                 {weakest:.1e} of the strongest, so small test errors move the estimates a lot"
            )
        } else {
            format!("the training tests determine every parameter ({})", names.join(", "))
        };
        return Identifiability {
            identifiable: true,
            note,
            singular_values: values,
            combinations: vec![],
        };
    }
    let note = if seen == 0 {
        "the training predictions do not depend on the parameters".to_string()
    } else {
        format!(
            "the parameters cannot be told apart: the training tests determine only {} — parameter sets \
             with the same {} predict the same, so the individual values reported are set by the search, \
             not by the data",
            combinations.join(", "),
            if seen == 1 { "value of it" } else { "values of these" },
        )
    };
    Identifiability {
        identifiable: false,
        note,
        singular_values: values,
        combinations,
    }
}

/// S_ij = (θ_j / y_i) ∂y_i/∂θ_j by central differences in the unit cube.
fn scaled_jacobian(problem: &Problem, theta: &DVector<f64>) -> DMatrix<f64> {
    let u = problem.bounds.to_unit(theta);
    let predict = |u: &DVector<f64>| problem.predictions(&problem.bounds.from_unit(u));
    let y = predict(&u);
    let width = problem.bounds.width();
    let raw = optimize::jacobian(&predict, &u);
    DMatrix::from_fn(raw.nrows(), raw.ncols(), |i, j| {
        raw[(i, j)] / width[j] * theta[j] / y[i]
    })
}

/// Π θ_j^{v_j} written with small exponents, e.g. `L^3/E`.
fn combination(names: &[String], direction: &[f64]) -> String {
    let biggest = direction.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let significant: Vec<(usize, f64)> = direction
        .iter()
        .copied()
        .enumerate()
        .filter(|(_, v)| v.abs() > 1e-3 * biggest)
        .collect();
    let smallest = significant.iter().fold(f64::INFINITY, |m, (_, v)| m.min(v.abs()));
    // Orient so the largest exponent is positive; scale so the smallest is ±1.
    let sign = significant
        .iter()
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map_or(1.0, |(_, v)| v.signum());
    let power = |name: &str, e: f64| {
        let e = e.abs();
        if (e - 1.0).abs() < 1e-3 {
            name.to_string()
        } else if (e - e.round()).abs() < 1e-3 {
            format!("{name}^{}", e.round())
        } else {
            format!("{name}^{e:.2}")
        }
    };
    let (mut num, mut den) = (vec![], vec![]);
    for (j, v) in significant {
        let e = sign * v / smallest;
        if e > 0.0 {
            num.push(power(&names[j], e))
        } else {
            den.push(power(&names[j], e))
        }
    }
    let num = if num.is_empty() {
        "1".to_string()
    } else {
        num.join("·")
    };
    match den.len() {
        0 => num,
        1 => format!("{num}/{}", den[0]),
        _ => format!("{num}/({})", den.join("·")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::testing::{cantilever, cantilever_el};

    fn names(n: &[&str]) -> Vec<String> {
        n.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn table1_only_l_cubed_over_e_is_identifiable() {
        let problem = cantilever_el(&[8.0, 10.0, 12.0]);
        let result = analyse(&problem, &names(&["E", "L"]), &DVector::from_vec(vec![60_000.0, 19.0]));
        assert!(!result.identifiable);
        assert_eq!(result.combinations, vec!["L^3/E".to_string()]);
        assert!(result.note.contains("L^3/E"), "{}", result.note);
    }

    #[test]
    fn one_parameter_from_two_tests_is_identifiable() {
        let result = analyse(
            &cantilever(&[8.0, 10.0]),
            &names(&["E"]),
            &DVector::from_vec(vec![60_000.0]),
        );
        assert!(result.identifiable, "{}", result.note);
        // ∂ln y/∂ln E = −1 at both designs: singular value √2 (±1e-6 for finite differences).
        assert!(
            (result.singular_values[0] - 2f64.sqrt()).abs() < 1e-6,
            "{:?}",
            result.singular_values
        );
    }

    #[test]
    fn two_parameters_from_one_test_are_not() {
        let result = analyse(
            &cantilever_el(&[8.0]),
            &names(&["E", "L"]),
            &DVector::from_vec(vec![60_000.0, 20.0]),
        );
        assert!(!result.identifiable);
        assert_eq!(result.combinations, vec!["L^3/E".to_string()]);
    }

    #[test]
    fn combination_formatting() {
        assert_eq!(combination(&names(&["a", "b"]), &[0.5, 0.5]), "a·b");
        assert_eq!(combination(&names(&["a", "b", "c"]), &[-1.0, -1.0, 2.0]), "c^2/(a·b)");
        assert_eq!(combination(&names(&["a", "b"]), &[1.0, 0.0]), "a");
    }
}
