//! Marks the GPU and Python tests ignored where no GPU adapter or Python is expected
//! (`test_cfg.rs`).

include!("test_cfg.rs");

fn main() {
    gpu_tests();
    python_tests();
}
