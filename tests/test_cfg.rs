// Which optional tests can run on this machine, decided when the tests are built.
//
// Tests that need a GPU adapter carry `#[cfg_attr(omnisim_no_gpu, ignore = ...)]`, tests that
// need the Python readers (`OMNISIM_PYTHON`) `#[cfg_attr(omnisim_no_python, ignore = ...)]`:
// where what they need is missing, `cargo test` counts them as ignored, with the reason,
// instead of passing them unrun. Where `CI` is set neither cfg is set: they run, and fail
// without what they need. `OMNISIM_GPU_TESTS=run` or `ignore` overrides the guess below. A
// test that runs and finds no adapter or Python fails (README, "Tests").
//
// The build script of every crate with such tests `include!`s this file and calls what its
// tests need.

use std::env;
use std::path::PathBuf;

/// Sets `omnisim_no_python` where `OMNISIM_PYTHON` is not set (and `CI` is not).
#[allow(dead_code, reason = "each build script calls what its tests need")]
fn python_tests() {
    declare(&["CI", "OMNISIM_PYTHON"], "omnisim_no_python");
    if env::var_os("CI").is_none() && env::var_os("OMNISIM_PYTHON").is_none() {
        println!("cargo::rustc-cfg=omnisim_no_python");
    }
}

/// Sets `omnisim_no_gpu` where no GPU adapter is expected (and `CI` is not set).
#[allow(dead_code, reason = "each build script calls what its tests need")]
fn gpu_tests() {
    declare(
        &[
            "CI",
            "OMNISIM_GPU_TESTS",
            "WGPU_BACKEND",
            "VK_DRIVER_FILES",
            "VK_ICD_FILENAMES",
            "VK_ADD_DRIVER_FILES",
            "XDG_CONFIG_DIRS",
            "XDG_CONFIG_HOME",
            "XDG_DATA_DIRS",
            "XDG_DATA_HOME",
            "HOME",
        ],
        "omnisim_no_gpu",
    );
    let gpu = match env::var("OMNISIM_GPU_TESTS").as_deref() {
        Ok("run") => true,
        Ok("ignore") => false,
        _ => adapter_expected(),
    };
    if env::var_os("CI").is_none() && !gpu {
        println!("cargo::rustc-cfg=omnisim_no_gpu");
    }
}

/// Reruns the build script when one of `vars` changes; declares `cfg`.
fn declare(vars: &[&str], cfg: &str) {
    for var in vars {
        println!("cargo::rerun-if-env-changed={var}");
    }
    println!("cargo::rustc-check-cfg=cfg({cfg})");
}

/// Whether a GPU adapter should open. Metal and DX12 (with its software WARP) are always
/// there; elsewhere wgpu needs a Vulkan driver, whose manifest the Vulkan loader finds through
/// these variables and `vulkan/icd.d` folders (lavapipe's is `lvp_icd.*.json`). A driver
/// installed later into a folder watched here is noticed; elsewhere, `OMNISIM_GPU_TESTS=run`.
fn adapter_expected() -> bool {
    let os = env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    if matches!(os.as_str(), "macos" | "ios" | "windows") {
        return true;
    }
    // Another backend asked for (WGPU_BACKEND=gl): no guess, let it try.
    if env::var("WGPU_BACKEND").is_ok_and(|backend| !backend.eq_ignore_ascii_case("vulkan")) {
        return true;
    }
    let listed = ["VK_DRIVER_FILES", "VK_ICD_FILENAMES", "VK_ADD_DRIVER_FILES"]
        .into_iter()
        .filter_map(env::var_os)
        .flat_map(|list| env::split_paths(&list).collect::<Vec<_>>());
    if listed.into_iter().any(|path| path.exists()) {
        return true;
    }
    let home = |below: &str| env::var_os("HOME").map(|home| PathBuf::from(home).join(below));
    let paths = |var: &str, default: Vec<PathBuf>| match env::var_os(var) {
        Some(list) if !list.is_empty() => env::split_paths(&list).collect(),
        _ => default,
    };
    let mut folders = paths("XDG_CONFIG_HOME", home(".config").into_iter().collect());
    folders.extend(paths("XDG_CONFIG_DIRS", vec!["/etc/xdg".into()]));
    folders.push("/etc".into());
    folders.extend(paths("XDG_DATA_HOME", home(".local/share").into_iter().collect()));
    folders.extend(paths("XDG_DATA_DIRS", vec!["/usr/local/share".into(), "/usr/share".into()]));
    let mut found = false;
    for vulkan in folders.iter().map(|folder| folder.join("vulkan")) {
        let drivers = vulkan.join("icd.d");
        // Watched where it exists (never a folder it does not: cargo would rerun every build).
        if let Some(watched) = [&drivers, &vulkan].into_iter().find(|f| f.is_dir()) {
            println!("cargo::rerun-if-changed={}", watched.display());
        }
        found |= std::fs::read_dir(&drivers).is_ok_and(|entries| {
            entries
                .filter_map(Result::ok)
                .any(|e| e.path().extension().is_some_and(|x| x == "json"))
        });
    }
    found
}
