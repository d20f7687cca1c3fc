pub mod bench;
pub mod render;
pub mod scene;
