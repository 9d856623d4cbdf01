//! PLACEHOLDER until the grid-io branch lands (helper is writing the real loaders).

#[derive(Clone, Debug, PartialEq)]
pub struct DenseGrid {
    pub dims: [usize; 3],
    pub data: Vec<f32>,
    pub bounds: Option<([f32; 3], [f32; 3])>,
}

#[derive(Debug, thiserror::Error)]
pub enum GridError {
    #[error("grid files are not supported yet")]
    Unsupported,
}

pub fn load_grid(_path: &std::path::Path, _grid: Option<&str>) -> Result<DenseGrid, GridError> {
    Err(GridError::Unsupported)
}
