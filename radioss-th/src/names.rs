//! Variable names by id, as the file stores only ids. The names are those OpenRadioss's own
//! converter (`th_to_csv`) writes for the same ids; `tests/th_to_csv.rs` checks every name of the
//! recorded files against its CSV header. Ids not listed here are named `VAR<id>`.

/// Group kind of `/TH/NODE` (and LS-DYNA's `*DATABASE_HISTORY_NODE`).
pub const KIND_NODE: i32 = 0;
/// Group kind of `/TH/INTER` (every contact of a converted LS-DYNA deck).
pub const KIND_INTERFACE: i32 = 101;

/// Global variables, ids 1 to 22.
const GLOBAL: [&str; 22] = [
    "INTERNAL ENERGY",
    "KINETIC ENERGY",
    "X-MOMENTUM",
    "Y-MOMENTUM",
    "Z-MOMENTUM",
    "MASS",
    "TIME STEP",
    "ROTATION ENERGY",
    "EXTERNAL WORK",
    "SPRING ENERGY",
    "CONTACT ENERGY",
    "HOURGLASS ENERGY",
    "ELASTIC CONTACT ENERGY",
    "FRICTIONAL CONTACT ENERGY",
    "DAMPING CONTACT ENERGY",
    "PLASTIC WORK",
    "ADDED MASS",
    "PERCENTAGE ADDED MASS",
    "INLET MASS",
    "OUTLET MASS",
    "INLET ENERGY",
    "OUTLET ENERGY",
];

/// Part variables by id.
const PART: [(i32, &str); 9] = [
    (1, "IE"),
    (2, "KE"),
    (3, "XMOM"),
    (4, "YMOM"),
    (5, "ZMOM"),
    (6, "MASS"),
    (7, "HE"),
    (25, "ERODED"),
    (28, "HEAT"),
];

/// Node variables, ids 1 to 15.
const NODE: [&str; 15] = [
    "DX", "DY", "DZ", "VX", "VY", "VZ", "AX", "AY", "AZ", "VRX", "VRY", "VRZ", "ARX", "ARY", "ARZ",
];

/// Interface variables, ids 1 to 6: normal and tangential components, stored as impulses
/// (force integrated over time); [`crate::TimeHistory::interface_force`] differentiates them.
const INTERFACE: [&str; 6] = ["FNX", "FNY", "FNZ", "FTX", "FTY", "FTZ"];

fn by_index(table: &[&str], id: i32) -> Option<String> {
    let i = usize::try_from(id).ok()?.checked_sub(1)?;
    table.get(i).map(|s| s.to_string())
}

fn unnamed(id: i32) -> String {
    format!("VAR{id}")
}

/// The name of global variable `id`.
pub fn global(id: i32) -> String {
    by_index(&GLOBAL, id).unwrap_or_else(|| unnamed(id))
}

/// The name of part variable `id`.
pub fn part(id: i32) -> String {
    PART.iter()
        .find(|(i, _)| *i == id)
        .map_or_else(|| unnamed(id), |(_, n)| n.to_string())
}

/// The name of variable `id` of a group of kind `kind`.
pub fn group_variable(kind: i32, id: i32) -> String {
    let table: &[&str] = match kind {
        KIND_NODE => &NODE,
        KIND_INTERFACE => &INTERFACE,
        _ => &[],
    };
    by_index(table, id).unwrap_or_else(|| unnamed(id))
}

/// Whether a group's values are impulses (cumulative), to be differentiated into forces.
pub fn is_impulse(kind: i32) -> bool {
    kind == KIND_INTERFACE
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_by_id_and_unknown_ids() {
        assert_eq!(global(1), "INTERNAL ENERGY");
        assert_eq!(global(18), "PERCENTAGE ADDED MASS");
        assert_eq!(global(99), "VAR99");
        assert_eq!(part(25), "ERODED");
        assert_eq!(part(8), "VAR8");
        assert_eq!(group_variable(KIND_NODE, 3), "DZ");
        assert_eq!(group_variable(KIND_INTERFACE, 3), "FNZ");
        assert_eq!(group_variable(KIND_INTERFACE, 0), "VAR0");
        assert_eq!(group_variable(7, 1), "VAR1");
    }
}
