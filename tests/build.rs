//! Marks the GPU tests ignored where no GPU adapter is expected (`test_cfg.rs`).

include!("test_cfg.rs");

fn main() {
    gpu_tests();
}
