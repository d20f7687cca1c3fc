pub mod bench;
pub mod poses;
pub mod render;
pub mod scene;
pub mod speed_accuracy;
