pub mod lsdyna;
pub mod mesh;
