//! Validation of `simulation.quality`: the gates on each run's energies (glstat, or the T01) (fractions in
//! (0, 1]) and `suspect: exclude | use`. Every error is at the offending value.

use super::super::schema::QualityFile;
use super::super::solver::QualitySettings;
use super::super::yaml::Spanned;
use super::Checker;
use crate::error::InputError;

impl Checker<'_> {
    pub(super) fn quality(&self, node: &Spanned<QualityFile>) -> Result<QualitySettings, InputError> {
        let q = &node.value;
        let mut out = QualitySettings::default();
        let gates = [
            (&q.hourglass, "hourglass", &mut out.gates.hourglass),
            (&q.energy, "energy", &mut out.gates.energy),
            (&q.added_mass, "added_mass", &mut out.gates.added_mass),
            (&q.kinetic, "kinetic", &mut out.gates.kinetic),
        ];
        for (value, key, slot) in gates {
            let Some(v) = value else { continue };
            if !(v.value > 0.0 && v.value <= 1.0) {
                return Err(self.at(
                    v,
                    format!(
                        "`quality.{key}` is {}: give a fraction in (0, 1], e.g. 0.1 for 10 %",
                        v.value
                    ),
                ));
            }
            *slot = v.value;
        }
        out.use_suspect = match q.suspect.as_ref().map(|s| (s, s.value.as_str())) {
            None | Some((_, "exclude")) => false,
            Some((_, "use")) => true,
            Some((s, other)) => {
                return Err(self.at(
                    s,
                    format!("unknown `quality.suspect: {other}`: choose exclude (the default) or use"),
                ));
            }
        };
        Ok(out)
    }
}
