//! Marks the GPU unit tests ignored where no adapter is expected (`tests/test_cfg.rs`).

include!("../../tests/test_cfg.rs");

fn main() {
    gpu_tests();
}
