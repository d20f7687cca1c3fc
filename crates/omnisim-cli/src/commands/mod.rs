pub mod bench;
pub mod render;
pub mod scene;
pub mod speed_accuracy;
