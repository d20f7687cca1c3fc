//! f32 image buffers kept for reuse by the thread that freed them.
//!
//! SIFT makes about sixteen images the size of the doubled input for every image it describes.
//! Freed, that much memory goes back to the kernel between images (glibc trims its heap), and
//! faulting the pages in and zeroing them again took 15 % of SIFT's time on a 512² image.

use std::cell::RefCell;

/// Most bytes of buffers one thread keeps (a 1024² image's pyramid needs about 250 MB).
const KEPT_BYTES: usize = 256 << 20;

thread_local! {
    static KEPT: RefCell<Vec<Vec<f32>>> = const { RefCell::new(Vec::new()) };
}

/// A buffer of `len` values for the caller to overwrite: the smallest kept buffer that holds
/// them, its old values left in place (not zeroed: that was a memset as long as the work it
/// saved), or new zeros.
pub(crate) fn take(len: usize) -> Vec<f32> {
    let kept = KEPT.with(|kept| {
        let mut kept = kept.borrow_mut();
        let best = (0..kept.len())
            .filter(|&i| kept[i].capacity() >= len)
            .min_by_key(|&i| kept[i].capacity());
        best.map(|i| kept.swap_remove(i))
    });
    match kept {
        Some(mut buffer) => {
            buffer.resize(len, 0.0);
            buffer
        }
        None => vec![0.0; len],
    }
}

/// Keeps `buffers` for [`take`] on this thread, up to [`KEPT_BYTES`] in all; the rest are
/// freed.
pub(crate) fn keep(buffers: impl IntoIterator<Item = Vec<f32>>) {
    KEPT.with(|kept| {
        let mut kept = kept.borrow_mut();
        let mut bytes: usize = kept.iter().map(|b| b.capacity() * size_of::<f32>()).sum();
        for buffer in buffers {
            let size = buffer.capacity() * size_of::<f32>();
            if bytes + size <= KEPT_BYTES {
                bytes += size;
                kept.push(buffer);
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A kept buffer comes back, at the asked length, for a request it can hold, the smallest
    /// that fits first; a larger request gets new zeros.
    #[test]
    fn kept_buffers_are_reused() {
        let (small, large) = (vec![1.0f32; 100], vec![2.0f32; 1000]);
        let (small_at, large_at) = (small.as_ptr(), large.as_ptr());
        keep([large, small]);
        let a = take(80);
        assert_eq!((a.as_ptr(), a.len()), (small_at, 80));
        let b = take(2000);
        assert!(b.as_ptr() != large_at && b.len() == 2000 && b.iter().all(|&v| v == 0.0));
        let mut c = take(10);
        assert_eq!(c.as_ptr(), large_at);
        keep([std::mem::take(&mut c)]);
        let d = take(1000);
        assert_eq!(d.as_ptr(), large_at);
    }
}
