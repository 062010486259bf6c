//! Read-only arrays in transparent huge pages. The path loop reads the BVH
//! nodes and packets, the per-primitive data and the texels at random; on
//! a large scene (staircase: ~60 MB of them) nearly every such read missed
//! the TLB with 4 KiB pages. Linux backs madvise(MADV_HUGEPAGE) mappings
//! with 2 MiB pages when the system's THP mode is `madvise` or `always`.
//!
//! The mapping is made here rather than taken from the allocator: a large
//! `Vec` may reuse heap pages the loader already touched, which stay small.
//!
//! [`prefetch`], the other half of reading such arrays at random, starts
//! loading an element before it is needed.

use std::ops::Deref;

const HUGE_PAGE: usize = 2 << 20;

/// An immutable slice, in huge pages when it spans at least one.
pub struct HugeSlice<T: Copy> {
    /// The elements, read without a branch on where they live.
    data: *const T,
    len: usize,
    owner: Owner<T>,
}

enum Owner<T> {
    Heap(#[allow(dead_code)] Vec<T>),
    /// The whole mapping, for munmap.
    Mapped {
        base: *mut u8,
        map_len: usize,
    },
}

// SAFETY: the elements are owned and never mutated after creation, like a
// `Box<[T]>`.
unsafe impl<T: Copy + Send> Send for HugeSlice<T> {}
// SAFETY: as above: shared access only reads.
unsafe impl<T: Copy + Sync> Sync for HugeSlice<T> {}

impl<T: Copy> HugeSlice<T> {
    pub fn new(items: Vec<T>) -> Self {
        let bytes = std::mem::size_of_val(items.as_slice());
        let mapped = if bytes >= HUGE_PAGE && std::mem::align_of::<T>() <= HUGE_PAGE {
            map_huge(bytes)
        } else {
            None
        };
        match mapped {
            Some((base, map_len, data)) => {
                let data = data as *mut T;
                // SAFETY: `data` is 2 MiB-aligned (so aligned for T), holds
                // `bytes` writable bytes and does not overlap `items`.
                unsafe { std::ptr::copy_nonoverlapping(items.as_ptr(), data, items.len()) };
                HugeSlice {
                    data,
                    len: items.len(),
                    owner: Owner::Mapped { base, map_len },
                }
            }
            None => HugeSlice {
                data: items.as_ptr(),
                len: items.len(),
                owner: Owner::Heap(items),
            },
        }
    }
}

/// An anonymous mapping with a 2 MiB-aligned region of `bytes` (rounded up
/// to whole huge pages) advised for huge pages: (mapping, its length, region).
#[cfg(target_os = "linux")]
fn map_huge(bytes: usize) -> Option<(*mut u8, usize, *mut u8)> {
    let region = bytes.next_multiple_of(HUGE_PAGE);
    let map_len = region + HUGE_PAGE;
    // SAFETY: a fresh private anonymous mapping; no existing memory is touched.
    let base = unsafe {
        libc::mmap(
            std::ptr::null_mut(),
            map_len,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_PRIVATE | libc::MAP_ANONYMOUS,
            -1,
            0,
        )
    };
    if base == libc::MAP_FAILED {
        return None;
    }
    let base = base as *mut u8;
    let data = (base as usize).next_multiple_of(HUGE_PAGE) as *mut u8;
    // SAFETY: [data, data + region) lies inside the mapping. A refused
    // advice only leaves the pages small.
    unsafe { libc::madvise(data as *mut libc::c_void, region, libc::MADV_HUGEPAGE) };
    Some((base, map_len, data))
}

#[cfg(not(target_os = "linux"))]
fn map_huge(_bytes: usize) -> Option<(*mut u8, usize, *mut u8)> {
    None
}

impl<T: Copy> Drop for HugeSlice<T> {
    fn drop(&mut self) {
        #[cfg(target_os = "linux")]
        if let Owner::Mapped { base, map_len } = self.owner {
            // SAFETY: the mapping made by `map_huge`, unmapped once.
            unsafe { libc::munmap(base as *mut libc::c_void, map_len) };
        }
    }
}

impl<T: Copy> Deref for HugeSlice<T> {
    type Target = [T];

    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: `len` initialised elements at `data`, owned by `owner`
        // (a Vec's buffer does not move while the Vec is not mutated).
        unsafe { std::slice::from_raw_parts(self.data, self.len) }
    }
}

impl<T: Copy> Clone for HugeSlice<T> {
    fn clone(&self) -> Self {
        HugeSlice::new(self.to_vec())
    }
}

impl<T: Copy + std::fmt::Debug> std::fmt::Debug for HugeSlice<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

/// Starts loading every cache line of `*p` without waiting for them.
#[inline(always)]
pub fn prefetch<T>(p: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let base = p as *const T as *const i8;
        for line in 0..std::mem::size_of::<T>().div_ceil(64) {
            // SAFETY: the address lies inside `*p`; a prefetch is a hint,
            // it never faults and reads nothing.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(base.add(line * 64)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_and_mapped_slices_keep_their_elements() {
        for n in [0usize, 10, (HUGE_PAGE / 4) * 3 + 17] {
            let v: Vec<u32> = (0..n as u32).map(|i| i.wrapping_mul(2654435761)).collect();
            let h = HugeSlice::new(v.clone());
            assert_eq!(&h[..], &v[..]);
            assert_eq!(&h.clone()[..], &v[..]);
        }
    }
}
