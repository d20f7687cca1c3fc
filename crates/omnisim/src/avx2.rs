//! A proof that the CPU has AVX2, passed to code that runs AVX2 instructions (the texture
//! filter's and sRGB encoding's here, SIFT's scan in
//! `omnisim-vision`), so that their `unsafe` rests on a value only the feature check makes,
//! not on which caller instantiates them; and [`Avx2::run`], which
//! compiles a closure's work for AVX2 (the textured runs' lanes).

/// Zero-sized proof that the running CPU has AVX2: its field is private, so one exists only
/// where [`Avx2::detected`] found the feature.
#[derive(Debug, Clone, Copy)]
pub struct Avx2(());

impl Avx2 {
    /// The proof, where the CPU has AVX2 (a cached check, cheap per call as the fast tracer
    /// takes it); `None` elsewhere, and on other architectures.
    #[inline(always)]
    pub fn detected() -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Some(Avx2(()));
        }
        None
    }

    /// `work()` compiled with AVX2, which the token proves the CPU has: wider vectors and
    /// gathers for the lanes `work` runs. Only where `work` is inlined into [`run_avx2`], so
    /// callers mark the closure `#[inline(always)]`: left out of line (LLVM's choice
    /// otherwise), it is compiled without AVX2.
    #[inline(always)]
    pub fn run<R>(self, work: impl FnOnce() -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: `self` proves the CPU has AVX2, which `run_avx2` is compiled for.
            unsafe { run_avx2(work) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        work()
    }
}

/// [`Avx2::run`]'s body, compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn run_avx2<R>(work: impl FnOnce() -> R) -> R {
    work()
}
