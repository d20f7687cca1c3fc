//! Marks the Python tests ignored where `OMNISIM_PYTHON` is not set (`tests/test_cfg.rs`).

include!("../../tests/test_cfg.rs");

fn main() {
    python_tests();
}
