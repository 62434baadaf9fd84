//! Study loading: YAML → schema → validated [`Study`].

use std::path::Path;

use super::Study;
use crate::error::InputError;

/// Loads and validates a study file and everything it references.
pub fn load(_path: &Path) -> Result<Study, InputError> {
    todo!("study::load")
}
