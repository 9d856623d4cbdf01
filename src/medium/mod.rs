pub mod grid_io;
