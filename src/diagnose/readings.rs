//! Known physical forms a discovered term may read as: data of the discovery library, not code.
//! Each form names its roles — design variables the form is written in — by the exponents that
//! identify them: the simulation's response y ∝ x^a (its local power law over the tested designs)
//! and the term's ratio to it g/y ∝ x^b; every design variable the form does not name must leave
//! g/y unchanged. A form is read as its words, each role's design variable in place of `{0}`,
//! `{1}`. A new field's law is one more entry of [`FORMS`].

/// How a role's variable must enter the term's ratio to the response.
#[derive(Debug, Clone, Copy)]
pub enum Ratio {
    /// g/y ∝ x^b.
    Is(f64),
    /// g/y ∝ x^(−b) where it is ∝ x^b in role `i` (a length beside a depth: only their ratio
    /// counts).
    MinusOf(usize),
}

/// One role of a form.
#[derive(Debug, Clone, Copy)]
pub struct Role {
    /// The response's exponent in the variable (`None`: any).
    pub response: Option<f64>,
    pub ratio: Ratio,
    /// The form still holds where no design variable takes this role (a beam tested at one
    /// length).
    pub optional: bool,
}

/// A known physical form.
#[derive(Debug, Clone, Copy)]
pub struct Form {
    pub roles: &'static [Role],
    pub words: &'static str,
}

const fn role(response: Option<f64>, ratio: Ratio, optional: bool) -> Role {
    Role {
        response,
        ratio,
        optional,
    }
}

/// The forms, tried in order.
pub const FORMS: &[Form] = &[
    // A beam: the response ∝ depth^-3 (bending); shear's share grows as (depth/length)².
    Form {
        roles: &[
            role(Some(-3.0), Ratio::Is(2.0), false),
            role(Some(3.0), Ratio::MinusOf(0), true),
        ],
        words: "shear-like: ∝ y·{0}² beside a response ∝ {0}^-3, the form of shear deformation beside bending in a \
                beam of depth {0} (Timoshenko: the shear share grows as the square of depth over length)",
    },
    // A compliant clamp: the root's rotation adds ∝ depth^-2 beside bending's depth^-3.
    Form {
        roles: &[
            role(Some(-3.0), Ratio::Is(1.0), false),
            role(Some(3.0), Ratio::MinusOf(0), true),
        ],
        words: "root-rotation-like: ∝ y·{0} (∝ {0}^-2) beside a response ∝ {0}^-3, the form of a compliant clamp's \
                rotation at the root of a beam of depth {0}",
    },
    // A crushed honeycomb: hardening's share of the fold-hinge flow stress ∝ (t/c)^(2/3).
    Form {
        roles: &[
            role(None, Ratio::Is(2.0 / 3.0), false),
            role(None, Ratio::Is(-2.0 / 3.0), false),
        ],
        words: "hardening-like: ∝ y·({0}/{1})^(2/3), the form of strain hardening's share of the flow stress in \
                the fold hinges of a crushed honeycomb (foil thickness {0}, cell size {1}; Wierzbicki's \
                super-folding element)",
    },
];

/// Exponents within this of a form's are the form's.
const NEAR: f64 = 1e-3;

fn near(a: f64, b: f64) -> bool {
    (a - b).abs() < NEAR
}

impl Form {
    /// The form's words for design variables `names`, given the response's exponents `ey` and the
    /// ratio's `er` in each (`None`: the term is not of this form).
    pub fn read(&self, names: &[String], ey: &[f64], er: &[f64]) -> Option<String> {
        let mut at = Vec::with_capacity(self.roles.len());
        self.assign(ey, er, &mut at)?;
        let mut words = self.words.to_string();
        for (i, j) in at.iter().enumerate() {
            if let Some(j) = j {
                words = words.replace(&format!("{{{i}}}"), &names[*j]);
            }
        }
        Some(words)
    }

    /// Roles assigned to distinct design variables in turn (`at[i]`: role i's, `None` for an
    /// optional role left out), the first assignment, in the variables' order, that fits.
    fn assign(&self, ey: &[f64], er: &[f64], at: &mut Vec<Option<usize>>) -> Option<()> {
        let i = at.len();
        let Some(role) = self.roles.get(i) else {
            // Every variable the form does not name leaves the ratio unchanged.
            let named = |j: usize| at.contains(&Some(j));
            return (0..er.len()).all(|j| named(j) || near(er[j], 0.0)).then_some(());
        };
        let free: Vec<usize> = (0..ey.len()).filter(|j| !at.contains(&Some(*j))).collect();
        for j in free {
            let response = role.response.is_none_or(|a| near(ey[j], a));
            let ratio = match role.ratio {
                Ratio::Is(b) => near(er[j], b),
                Ratio::MinusOf(k) => at[k].is_some_and(|h| near(er[j], -er[h])),
            };
            if response && ratio {
                at.push(Some(j));
                if self.assign(ey, er, at).is_some() {
                    return Some(());
                }
                at.pop();
            }
        }
        if role.optional {
            at.push(None);
            if self.assign(ey, er, at).is_some() {
                return Some(());
            }
            at.pop();
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: &[&str]) -> Vec<String> {
        n.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn a_beam_reads_as_shear_or_root_rotation_with_or_without_its_length() {
        let beam = names(&["h", "L"]);
        // y ∝ L³/h³; shear ∝ y·(h/L)², root rotation ∝ y·h/L.
        let shear = FORMS[0].read(&beam, &[-3.0, 3.0], &[2.0, -2.0]).unwrap();
        assert!(shear.starts_with("shear-like: ∝ y·h²"), "{shear}");
        assert!(FORMS[1].read(&beam, &[-3.0, 3.0], &[1.0, -1.0]).is_some());
        // At one length the form is read from the depth alone.
        assert!(FORMS[0].read(&names(&["h"]), &[-3.0], &[2.0]).is_some());
        // A ratio that grows with length is not shear's.
        assert!(FORMS[0].read(&beam, &[-3.0, 3.0], &[2.0, 1.0]).is_none());
    }

    #[test]
    fn a_honeycomb_reads_as_hardening_in_either_order_of_its_variables() {
        let hc = names(&["c", "t"]);
        let words = FORMS[2]
            .read(&hc, &[-1.0, 5.0 / 3.0], &[-2.0 / 3.0, 2.0 / 3.0])
            .unwrap();
        assert!(words.contains("(t/c)^(2/3)"), "{words}");
        // A third variable that changes the ratio breaks the form.
        assert!(
            FORMS[2]
                .read(&names(&["c", "t", "d"]), &[0.0; 3], &[-2.0 / 3.0, 2.0 / 3.0, 0.5])
                .is_none()
        );
    }
}
