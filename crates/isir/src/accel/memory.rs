//! Large arrays of the acceleration structures on huge pages.
//!
//! A tree of ten million triangles is half a gigabyte read at random: with 4 KB pages
//! nearly every node a ray visits also misses the TLB and waits for a page walk. Linux
//! backs memory with 2 MB pages where a program asks for them (`madvise(MADV_HUGEPAGE)`
//! when `transparent_hugepage` is `madvise`, the common default), as Embree does for its
//! trees. Only a hint: where the kernel has none to give, nothing changes.

/// Arrays smaller than this stay as they are (a few huge pages at most; the TLB covers them).
const HUGE_FROM: usize = 8 << 20;

/// A vector with room for `capacity` elements whose memory is advised to be backed by huge
/// pages, before anything is written to it (pages are chosen when first touched).
pub(crate) fn vec_on_huge_pages<T>(capacity: usize) -> Vec<T> {
    let v: Vec<T> = Vec::with_capacity(capacity);
    advise_huge_pages(v.as_ptr().cast(), v.capacity() * std::mem::size_of::<T>());
    v
}

#[cfg(target_os = "linux")]
fn advise_huge_pages(ptr: *const u8, bytes: usize) {
    const PAGE: usize = 4096;
    if bytes < HUGE_FROM {
        return;
    }
    // The whole pages inside the allocation.
    let start = (ptr as usize).next_multiple_of(PAGE);
    let end = (ptr as usize + bytes) / PAGE * PAGE;
    if end > start {
        // SAFETY: the range lies inside an allocation this process owns (the vector's
        // buffer), and MADV_HUGEPAGE only changes how the kernel backs it, never its
        // contents. A failure (an old kernel, huge pages disabled) leaves it as it was.
        unsafe { libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE) };
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_ptr: *const u8, _bytes: usize) {}

/// Elements `from..to` of `v`'s capacity (clamped to it), as an address range for
/// [`populate`]: taken before another thread starts writing the vector.
pub(crate) fn spare_range<T>(v: &Vec<T>, from: usize, to: usize) -> (usize, usize) {
    let (base, size) = (v.as_ptr() as usize, std::mem::size_of::<T>());
    (base + from.min(v.capacity()) * size, base + to.min(v.capacity()) * size)
}

/// Asks the kernel to fault in the whole pages of the address range `(start, end)` (from
/// [`spare_range`]) now, as if written, without writing them: a thread with nothing else
/// to do takes the page faults (the zeroing of fresh pages) that the thread about to
/// write there would otherwise wait for. The contents do not change, so another thread
/// may be writing the range meanwhile. A kernel without `MADV_POPULATE_WRITE` (before
/// Linux 5.14) declines, and nothing happens.
#[cfg(target_os = "linux")]
pub(crate) fn populate((start, end): (usize, usize)) {
    const PAGE: usize = 4096;
    let (start, end) = (start.next_multiple_of(PAGE), end / PAGE * PAGE);
    if end > start {
        // SAFETY: the range lies inside an allocation this process owns (a vector's
        // buffer, `spare_range`), and MADV_POPULATE_WRITE only faults its pages in,
        // never changing what they hold.
        unsafe { libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_POPULATE_WRITE) };
    }
}

#[cfg(not(target_os = "linux"))]
pub(crate) fn populate(_range: (usize, usize)) {}

/// The size of the CPU's last-level cache in bytes (Linux: the highest cache level
/// `sysfs` lists for the first CPU), 32 MiB where it cannot be read. Read once.
pub fn last_level_cache_bytes() -> usize {
    static BYTES: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *BYTES.get_or_init(|| read_last_level_cache().unwrap_or(32 << 20))
}

#[cfg(target_os = "linux")]
fn read_last_level_cache() -> Option<usize> {
    let dir = std::path::Path::new("/sys/devices/system/cpu/cpu0/cache");
    let read = |index: &std::path::Path, what: &str| std::fs::read_to_string(index.join(what)).ok();
    std::fs::read_dir(dir)
        .ok()?
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with("index"))
        .filter_map(|e| {
            let index = e.path();
            let level: u32 = read(&index, "level")?.trim().parse().ok()?;
            let kind = read(&index, "type")?;
            (kind.trim() != "Instruction").then_some(())?;
            Some((level, cache_size_bytes(&read(&index, "size")?)?))
        })
        .max()
        .map(|(_, bytes)| bytes)
}

#[cfg(not(target_os = "linux"))]
fn read_last_level_cache() -> Option<usize> {
    None
}

/// A `sysfs` cache size (`"32768K"`, `"1M"`, `"512"`) in bytes.
#[cfg_attr(not(target_os = "linux"), allow(dead_code))]
fn cache_size_bytes(text: &str) -> Option<usize> {
    let t = text.trim();
    let (digits, unit) = match t.char_indices().find(|(_, c)| !c.is_ascii_digit()) {
        Some((i, _)) => t.split_at(i),
        None => (t, ""),
    };
    let n: usize = digits.parse().ok()?;
    let scale = match unit {
        "" => 1,
        "K" | "k" => 1 << 10,
        "M" => 1 << 20,
        "G" => 1 << 30,
        _ => return None,
    };
    n.checked_mul(scale).filter(|&b| b > 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cache_sizes_are_read_as_sysfs_writes_them() {
        assert_eq!(cache_size_bytes("32768K\n"), Some(32 << 20));
        assert_eq!(cache_size_bytes("1M"), Some(1 << 20));
        assert_eq!(cache_size_bytes("512"), Some(512));
        for bad in ["", "K", "12Q", "0K", "-1K", "99999999999999999999K"] {
            assert_eq!(cache_size_bytes(bad), None, "{bad:?}");
        }
        // Whatever the machine, a size a CPU could have.
        assert!((64 << 10..=4 << 30).contains(&last_level_cache_bytes()));
    }

    #[test]
    fn vectors_on_huge_pages_are_ordinary_vectors() {
        for n in [0, 1, 1000, HUGE_FROM / 4 + 3] {
            let mut v: Vec<u32> = vec_on_huge_pages(n);
            assert!(v.capacity() >= n);
            v.extend((0..n as u32).rev());
            assert_eq!(v.len(), n);
            assert!(v.iter().enumerate().all(|(i, &x)| x as usize == n - 1 - i));
        }
    }

    /// Faulting pages in never changes what they hold: neither the written elements nor,
    /// through a range given past them, anything written there later.
    #[test]
    fn populate_keeps_the_contents() {
        let n = 3 << 20;
        let mut v: Vec<u32> = vec_on_huge_pages(2 * n);
        v.extend((0..n as u32).map(|x| x.wrapping_mul(2_654_435_761)));
        populate(spare_range(&v, 0, n));
        populate(spare_range(&v, n / 2, usize::MAX));
        assert_eq!(spare_range(&v, 0, usize::MAX).1, spare_range(&v, 0, v.capacity()).1, "clamped to the capacity");
        v.extend(0..n as u32);
        assert!(v[..n].iter().enumerate().all(|(i, &x)| x == (i as u32).wrapping_mul(2_654_435_761)));
        assert!(v[n..].iter().enumerate().all(|(i, &x)| x as usize == i));
    }

    /// Where the kernel has `MADV_POPULATE_WRITE` (Linux 5.14), the range's pages are
    /// resident afterwards (`mincore`), not before.
    #[cfg(target_os = "linux")]
    #[test]
    fn populate_faults_the_pages_in() {
        let release = std::fs::read_to_string("/proc/sys/kernel/osrelease").expect("the kernel's release");
        let mut parts = release.trim().split(['.', '-']).map(|p| p.parse::<u32>().unwrap_or(0));
        let (major, minor) = (parts.next().unwrap_or(0), parts.next().unwrap_or(0));
        const PAGE: usize = 4096;
        // Above glibc's largest mmap threshold (32 MB): fresh pages, never a freed chunk.
        let bytes = 64 << 20;
        let v: Vec<u8> = Vec::with_capacity(bytes + PAGE);
        let start = (v.as_ptr() as usize).next_multiple_of(PAGE);
        let resident = || {
            let mut flags = vec![0u8; bytes / PAGE];
            // SAFETY: the range is whole pages inside `v`'s buffer, and `flags` has a byte
            // per page.
            let r = unsafe { libc::mincore(start as *mut libc::c_void, bytes, flags.as_mut_ptr()) };
            assert_eq!(r, 0, "mincore");
            flags.iter().filter(|&&f| f & 1 != 0).count()
        };
        let before = resident();
        populate((start, start + bytes));
        let after = resident();
        if (major, minor) >= (5, 14) {
            assert!(before < bytes / PAGE / 2, "{before} pages resident before anything was written");
            assert_eq!(after, bytes / PAGE, "Linux {}: pages resident after populate", release.trim());
        } else {
            eprintln!("Linux {} has no MADV_POPULATE_WRITE: only checked that populate does no harm", release.trim());
        }
        drop(v);
    }

    /// The kernel takes the advice: the mapping holding a large vector may be backed by
    /// huge pages whenever transparent huge pages are not off (`[never]`).
    #[cfg(target_os = "linux")]
    #[test]
    fn large_vectors_are_eligible_for_huge_pages() {
        // A kernel built without transparent huge pages has no such file: as `[never]`.
        let mode = std::fs::read_to_string("/sys/kernel/mm/transparent_hugepage/enabled").unwrap_or_else(|_| "[never]".into());
        let v: Vec<u8> = vec_on_huge_pages(64 << 20);
        let addr = v.as_ptr() as usize + (32 << 20);
        let smaps = std::fs::read_to_string("/proc/self/smaps").unwrap();
        let mut eligible = None;
        let mut inside = false;
        for line in smaps.lines() {
            if let Some((range, _)) = line.split_once(' ') {
                if let Some((lo, hi)) = range.split_once('-') {
                    if let (Ok(lo), Ok(hi)) = (usize::from_str_radix(lo, 16), usize::from_str_radix(hi, 16)) {
                        inside = (lo..hi).contains(&addr);
                        continue;
                    }
                }
            }
            if inside {
                if let Some(flag) = line.strip_prefix("THPeligible:") {
                    eligible = Some(flag.trim() == "1");
                }
            }
        }
        if mode.contains("[never]") {
            assert_ne!(eligible, Some(true), "transparent huge pages are off");
        } else {
            assert_eq!(eligible, Some(true), "the vector's mapping in /proc/self/smaps (transparent_hugepage/enabled: {mode})");
        }
    }
}
