//! Bounded reading of input files (meshes, material libraries, ray files).
//!
//! An input file is read whole into memory, so what is read must be bounded by what the
//! file really holds and by a limit, never by what it claims:
//!
//! - Only regular files are read. The kind is checked with `metadata` before the file is
//!   opened, so a FIFO never blocks and `/dev/zero` or a directory is refused at once
//!   ("/dev/zero: not a regular file (a character device)").
//! - A file larger than [`ReadLimits::max_bytes`] is refused before it is read; a `.gz`
//!   file is decompressed (every member, as parallel gzip tools write them) and stops with
//!   an error as soon as its decompressed size passes the same limit, so a small gzip bomb
//!   cannot exhaust memory. Bytes after the last member that do not start another are an
//!   error that counts them ("8 bytes after the end of the gzip data (at byte 52) are not
//!   gzip"), and so is data that is gzip again once decompressed ("compressed twice").
//! - A BGZF file (the blocked gzip of `bgzip`, whose members each say their size in a
//!   header field) is inflated on every thread, member by member, into one buffer sized
//!   by the members' trailers (each at most 64 KiB, the format's bound, and their sum
//!   within the limit; allocated zeroed, so only what really inflates takes memory);
//!   anything unexpected in it (a damaged member, a size that does not match, a sum over
//!   the limit) sends the whole file through the one-thread reader, whose answer or error
//!   it then is. The built-in conference room is shipped so (`tools/bgzf.py`).
//! - The limit is 1 GiB by default ([`ReadLimits::DEFAULT_MAX_BYTES`]).
//!   [`ReadLimits::from_env`] reads a different one from the `ISIR_MAX_INPUT_BYTES`
//!   environment variable (bytes, or with a `K`, `M`, `G` or `T` suffix, powers of 1024),
//!   which is what [`crate::io::obj::load_obj`] uses, so the `isir` command honours it.

use crate::error::{Error, Result};
use std::io::Read;
use std::path::Path;

/// How much an input file may hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadLimits {
    /// The most bytes a file may hold, after decompression for `.gz` files (and before:
    /// a compressed file is never larger than what it inflates to, for real inputs).
    pub max_bytes: u64,
}

impl ReadLimits {
    /// The default limit: 1 GiB, ten times the largest course model once decompressed,
    /// and small enough that a machine with a few GB of memory survives it.
    pub const DEFAULT_MAX_BYTES: u64 = 1 << 30;

    /// The environment variable read by [`Self::from_env`].
    pub const ENV_VAR: &'static str = "ISIR_MAX_INPUT_BYTES";

    /// A limit of `max_bytes`.
    #[must_use]
    pub fn new(max_bytes: u64) -> Self {
        Self { max_bytes }
    }

    /// The limit named by `ISIR_MAX_INPUT_BYTES`, or the default when it is not set.
    ///
    /// # Errors
    /// The variable is set but is not a byte count; the message says so and names it.
    pub fn from_env() -> std::result::Result<Self, String> {
        Self::from_env_value(std::env::var_os(Self::ENV_VAR).as_deref())
    }

    /// The limit for a value of `ISIR_MAX_INPUT_BYTES` (`None`: not set, the default).
    ///
    /// # Errors
    /// As [`Self::from_env`].
    pub fn from_env_value(value: Option<&std::ffi::OsStr>) -> std::result::Result<Self, String> {
        match value {
            None => Ok(Self::default()),
            Some(v) => {
                let v = v.to_string_lossy();
                Self::parse_max_bytes(&v).map(Self::new).map_err(|e| format!("{}='{v}': {e}", Self::ENV_VAR))
            }
        }
    }

    /// Parse a byte count: digits, optionally followed by `K`, `M`, `G` or `T` (powers of
    /// 1024; `KiB`, `MB`... are accepted too, all binary).
    ///
    /// # Errors
    /// Not such a count, zero, or more than `u64` holds.
    pub fn parse_max_bytes(s: &str) -> std::result::Result<u64, String> {
        let s = s.trim();
        let digits = s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len());
        let (number, unit) = s.split_at(digits);
        let shift = match unit.trim().to_ascii_uppercase().as_str() {
            "" | "B" => 0,
            "K" | "KB" | "KIB" => 10,
            "M" | "MB" | "MIB" => 20,
            "G" | "GB" | "GIB" => 30,
            "T" | "TB" | "TIB" => 40,
            _ => return Err("expected a number of bytes, optionally with a K, M, G or T suffix (e.g. 4G)".into()),
        };
        let n: u64 = number.parse().map_err(|_| "expected a number of bytes, optionally with a K, M, G or T suffix (e.g. 4G)")?;
        let bytes = n.checked_mul(1 << shift).ok_or("too large")?;
        if bytes == 0 {
            return Err("the limit must be at least 1 byte".into());
        }
        Ok(bytes)
    }

    fn too_large(&self, path: &Path, what: String) -> Error {
        Error::Input { path: path.to_path_buf(), message: format!("{what} more than {}", self.described()) }
    }

    /// `the input limit of 1 GiB (set ISIR_MAX_INPUT_BYTES to raise it)`, for the messages
    /// of everything the limit bounds.
    pub(crate) fn described(&self) -> String {
        format!("the input limit of {} (set {} to raise it)", human_bytes(self.max_bytes), Self::ENV_VAR)
    }
}

impl Default for ReadLimits {
    fn default() -> Self {
        Self::new(Self::DEFAULT_MAX_BYTES)
    }
}

/// `n` bytes, in the largest binary unit that divides it (`1 GiB`, `1536 KiB`, `1000 bytes`).
fn human_bytes(n: u64) -> String {
    for (shift, unit) in [(40, "TiB"), (30, "GiB"), (20, "MiB"), (10, "KiB")] {
        if n >= 1 << shift && n.is_multiple_of(1 << shift) {
            return format!("{} {unit}", n >> shift);
        }
    }
    format!("{n} bytes")
}

/// What a non-regular file is, for the message that refuses it.
fn file_kind(t: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else {
        "not a file"
    }
}

/// Read a regular file whole, decompressing it when its name ends in `.gz`, within `limits`.
///
/// # Errors
/// [`Error::Input`] when the file is not a regular file or holds (or inflates to) more
/// than the limit; [`Error::Io`] when it cannot be read or is not valid gzip. Both name
/// the file.
pub fn read_file(path: &Path, limits: &ReadLimits) -> Result<Vec<u8>> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    // metadata, not open: opening a FIFO blocks until someone writes to it.
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(Error::Input { path: path.to_path_buf(), message: format!("not a regular file ({})", file_kind(meta.file_type())) });
    }
    if meta.len() > limits.max_bytes {
        return Err(limits.too_large(path, format!("{} bytes,", meta.len())));
    }
    let file = std::fs::File::open(path).map_err(io)?;
    // The path may have been replaced since `metadata`: whatever it is now, at most
    // `max_bytes + 1` bytes are read from it.
    let bounded = file.take(limits.max_bytes.saturating_add(1));
    if path.extension().is_some_and(|e| e == "gz") {
        // Within the limit: a compressed file larger than it was refused above.
        let raw = read_bounded(path, bounded, meta.len(), limits, "holds")?;
        gunzip(path, &raw, limits)
    } else {
        // The size the file system gives for a regular file is what the file holds (and
        // it is within the limit): a good first capacity.
        read_bounded(path, bounded, meta.len(), limits, "holds")
    }
}

/// [`read_file`] for the files a mesh file names (material libraries, textures, glTF
/// buffers and images), each noted as it is asked for, read or not: what the load read
/// besides the mesh ([`crate::io::obj::LoadedMesh::files`]).
#[derive(Debug, Default)]
pub(crate) struct ReadLog(std::cell::RefCell<Vec<std::path::PathBuf>>);

impl ReadLog {
    /// [`read_file`], `path` noted.
    pub(crate) fn read(&self, path: &Path, limits: &ReadLimits) -> Result<Vec<u8>> {
        self.0.borrow_mut().push(path.to_path_buf());
        read_file(path, limits)
    }

    /// The files asked for, in order.
    pub(crate) fn into_files(self) -> Vec<std::path::PathBuf> {
        self.0.into_inner()
    }
}

/// Decompress gzip bytes (every member) within `limits`; `name` names them in messages.
///
/// # Errors
/// Not valid gzip, or more than the limit once decompressed.
pub fn gunzip(name: &Path, raw: &[u8], limits: &ReadLimits) -> Result<Vec<u8>> {
    let out = gunzip_once(name, raw, limits)?;
    // No input isir reads starts so: the data was compressed again after compression.
    if out.starts_with(&GZIP_MAGIC) {
        return Err(Error::Input {
            path: name.to_path_buf(),
            message: "the file is compressed twice (gzip inside gzip): decompress it once".into(),
        });
    }
    Ok(out)
}

/// The first bytes of a gzip member: its magic number and the deflate method.
const GZIP_MAGIC: [u8; 3] = [0x1f, 0x8b, 8];

/// [`gunzip`], one layer of compression.
fn gunzip_once(name: &Path, raw: &[u8], limits: &ReadLimits) -> Result<Vec<u8>> {
    if let Some(members) = bgzf_members(raw) {
        // More than the limit by the trailers' word: the one-thread reader stops at the
        // limit by what really inflates (or at the first damaged member).
        let size: u64 = members.iter().map(|m| u64::from(m.size)).sum();
        if size <= limits.max_bytes {
            if let Some(out) = inflate_members(raw, &members, size) {
                return Ok(out);
            }
        }
    }
    read_bounded(name, Members::new(raw), inflated_guess(raw.len() as u64), limits, "decompresses to")
}

/// Every gzip member of `raw` in turn, read as one stream: `flate2`'s `MultiGzDecoder`,
/// except that bytes after a member that do not start another are an error that says
/// so (the decoder took them for a damaged member: "unexpected end of file" or "invalid
/// gzip header").
struct Members<'a> {
    raw: &'a [u8],
    /// The member being read (the first from the start, whatever its bytes).
    member: Option<flate2::bufread::GzDecoder<&'a [u8]>>,
}

impl<'a> Members<'a> {
    fn new(raw: &'a [u8]) -> Self {
        Self { raw, member: Some(flate2::bufread::GzDecoder::new(raw)) }
    }
}

impl Read for Members<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        loop {
            if let Some(member) = &mut self.member {
                let n = member.read(buf)?;
                if n > 0 {
                    return Ok(n);
                }
                // The member has ended, its trailer checked: what follows it.
                let rest = self.member.take().map_or(&[][..], flate2::bufread::GzDecoder::into_inner);
                if rest.is_empty() {
                    return Ok(0);
                }
                if !rest.starts_with(&GZIP_MAGIC[..2]) {
                    let at = self.raw.len() - rest.len();
                    return Err(std::io::Error::new(
                        std::io::ErrorKind::InvalidData,
                        format!("{} bytes after the end of the gzip data (at byte {at}) are not gzip", rest.len()),
                    ));
                }
                self.member = Some(flate2::bufread::GzDecoder::new(rest));
            } else {
                return Ok(0);
            }
        }
    }
}

/// A BGZF member: its bytes in the file and the size its trailer gives.
struct Member {
    bytes: std::ops::Range<usize>,
    size: u32,
}

/// The largest member BGZF allows, compressed or not.
const BGZF_BLOCK: usize = 1 << 16;

/// The members of `raw` when it is BGZF from end to end, as `bgzip` writes it: each a
/// gzip member whose only extra field is `BC`, which gives its size; `None` otherwise,
/// or for a single member (nothing to share out).
fn bgzf_members(raw: &[u8]) -> Option<Vec<Member>> {
    let mut members = Vec::new();
    let mut at = 0;
    while at < raw.len() {
        let h = raw.get(at..at + 18)?;
        // Magic, deflate, FEXTRA only; XLEN 6; subfield `BC` of 2 bytes: the size - 1.
        if h[..4] != [0x1f, 0x8b, 8, 4] || h[10..16] != [6, 0, b'B', b'C', 2, 0] {
            return None;
        }
        let len = usize::from(u16::from_le_bytes([h[16], h[17]])) + 1;
        // The header, the trailer and at least an empty deflate block.
        let member = raw.get(at..at + len).filter(|m| m.len() >= 18 + 2 + 8)?;
        let size = u32::from_le_bytes(member[len - 4..].try_into().ok()?);
        if size as usize > BGZF_BLOCK {
            return None;
        }
        members.push(Member { bytes: at..at + len, size });
        at += len;
    }
    (members.len() > 1).then_some(members)
}

/// The members inflated on every thread into one buffer of `size` bytes; `None` when one
/// does not inflate to exactly its trailer's size with a good checksum. The buffer is
/// allocated zeroed, so its pages are only taken as data really inflates into them.
fn inflate_members(raw: &[u8], members: &[Member], size: u64) -> Option<Vec<u8>> {
    use rayon::prelude::*;
    let mut out = vec![0u8; usize::try_from(size).ok()?];
    let pieces = super::pieces_mut(&mut out, members.iter().map(|m| m.size as usize));
    let whole = pieces.into_par_iter().zip(members).all(|(piece, m)| {
        let mut d = flate2::read::GzDecoder::new(&raw[m.bytes.clone()]);
        // Reading past the data checks the trailer (CRC-32 and size).
        d.read_exact(piece).is_ok() && matches!(d.read(&mut [0u8; 1]), Ok(0))
    });
    whole.then_some(out)
}

/// A first capacity for what `compressed` bytes of gzip inflate to: four times as much
/// (text meshes compress about 4:1). It comes from the bytes really there, not from the
/// size the gzip trailer claims, and the buffer grows from it only as data arrives.
fn inflated_guess(compressed: u64) -> u64 {
    compressed.saturating_mul(4)
}

/// Read `reader` to its end, or stop with an error once it yields more than the limit.
/// The buffer grows with what is really read (`capacity` only when it is known true).
fn read_bounded(path: &Path, reader: impl Read, capacity: u64, limits: &ReadLimits, what: &str) -> Result<Vec<u8>> {
    let mut out = Vec::with_capacity(usize::try_from(capacity.min(limits.max_bytes)).unwrap_or(0));
    reader
        .take(limits.max_bytes.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
    if out.len() as u64 > limits.max_bytes {
        return Err(limits.too_large(path, what.to_string()));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// A fresh directory, removed when the test ends (failing too), and `name` in it.
    fn tmp(name: &str) -> (tempfile::TempDir, std::path::PathBuf) {
        let dir = tempfile::Builder::new().prefix("isir-input-").tempdir().unwrap();
        let path = dir.path().join(name);
        (dir, path)
    }

    fn gz(data: &[u8]) -> Vec<u8> {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        e.write_all(data).unwrap();
        e.finish().unwrap()
    }

    #[test]
    fn devices_and_directories_are_refused_without_reading() {
        let t = std::time::Instant::now();
        let e = read_file(Path::new("/dev/zero"), &ReadLimits::default()).unwrap_err().to_string();
        assert_eq!(e, "/dev/zero: not a regular file (a character device)");
        let e = read_file(&std::env::temp_dir(), &ReadLimits::default()).unwrap_err().to_string();
        assert!(e.ends_with("not a regular file (a directory)"), "{e}");
        assert!(t.elapsed().as_secs() < 2, "refused at once");
    }

    #[test]
    fn a_fifo_is_refused_without_blocking() {
        let (_dir, p) = tmp("fifo");
        let _ = std::fs::remove_file(&p);
        let made = std::process::Command::new("mkfifo").arg(&p).status().expect("mkfifo runs");
        assert!(made.success());
        let (tx, rx) = std::sync::mpsc::channel();
        let q = p.clone();
        // Opening a FIFO blocks until a writer comes: read in a thread so a regression
        // fails this test instead of hanging the suite.
        std::thread::spawn(move || tx.send(read_file(&q, &ReadLimits::default()).map_err(|e| e.to_string())));
        let e = rx.recv_timeout(std::time::Duration::from_secs(5)).expect("read_file returns").unwrap_err();
        assert!(e.ends_with("fifo: not a regular file (a FIFO)"), "{e}");
    }

    #[test]
    fn files_over_the_limit_are_refused() {
        let (_dir, p) = tmp("big.txt");
        std::fs::write(&p, vec![b'x'; 3000]).unwrap();
        assert_eq!(read_file(&p, &ReadLimits::new(3000)).unwrap().len(), 3000);
        let e = read_file(&p, &ReadLimits::new(2048)).unwrap_err().to_string();
        assert!(e.contains("big.txt: 3000 bytes, more than the input limit of 2 KiB") && e.contains("ISIR_MAX_INPUT_BYTES"), "{e}");
    }

    #[test]
    fn gzip_bombs_stop_at_the_limit() {
        // 16 MiB of zeros in about 16 KiB: inflating stops just past the 1 MiB limit.
        let bomb = gz(&vec![0u8; 16 << 20]);
        assert!(bomb.len() < 100_000);
        let (_dir, p) = tmp("bomb.obj.gz");
        std::fs::write(&p, &bomb).unwrap();
        let e = read_file(&p, &ReadLimits::new(1 << 20)).unwrap_err().to_string();
        assert!(e.contains("bomb.obj.gz: decompresses to more than the input limit of 1 MiB"), "{e}");
        let e = gunzip(Path::new("m.gz"), &bomb, &ReadLimits::new(1 << 20)).unwrap_err().to_string();
        assert!(e.starts_with("m.gz: decompresses to more than"), "{e}");
        assert_eq!(read_file(&p, &ReadLimits::new(16 << 20)).unwrap().len(), 16 << 20);
    }

    #[test]
    fn every_gzip_member_is_read() {
        let mut two = gz(b"first member\n");
        two.extend(gz(b"second member\n"));
        let (_dir, p) = tmp("two.txt.gz");
        std::fs::write(&p, &two).unwrap();
        assert_eq!(read_file(&p, &ReadLimits::default()).unwrap(), b"first member\nsecond member\n");
        // A damaged or cut stream is an error, not a silently shorter file.
        std::fs::write(&p, &two[..two.len() - 5]).unwrap();
        assert!(read_file(&p, &ReadLimits::default()).unwrap_err().to_string().contains("two.txt.gz"));
    }

    #[test]
    fn bytes_after_the_gzip_data_are_named_as_such() {
        let mut trail = gz(b"v 0 0 0\n");
        let end = trail.len();
        trail.extend(b"garbage\n");
        let limits = ReadLimits::default();
        let e = gunzip(Path::new("trail.obj.gz"), &trail, &limits).unwrap_err().to_string();
        assert_eq!(e, format!("trail.obj.gz: 8 bytes after the end of the gzip data (at byte {end}) are not gzip"));
        // After the second of two members, and after BGZF (then not BGZF: read on one thread).
        let mut two = gz(b"a\n");
        two.extend(gz(b"b\n"));
        let at = two.len();
        two.extend([0u8; 3]);
        let e = gunzip(Path::new("m.gz"), &two, &limits).unwrap_err().to_string();
        assert!(e.ends_with(&format!("3 bytes after the end of the gzip data (at byte {at}) are not gzip")), "{e}");
        let mut blocked = bgzf(b"v 1 2 3\n");
        blocked.push(b'x');
        let e = gunzip(Path::new("m.gz"), &blocked, &limits).unwrap_err().to_string();
        assert!(e.contains("1 bytes after the end of the gzip data"), "{e}");
        // A third member cut short is still a damaged member, not bytes of something else.
        let mut cut = gz(b"a\n");
        cut.extend(&gz(b"b\n")[..6]);
        let e = gunzip(Path::new("m.gz"), &cut, &limits).unwrap_err().to_string();
        assert!(!e.contains("not gzip"), "{e}");
    }

    #[test]
    fn members_read_as_flate2s_multi_member_decoder_reads_them() {
        let flate2 = |raw: &[u8]| {
            let mut out = Vec::new();
            flate2::read::MultiGzDecoder::new(raw).read_to_end(&mut out).map(|_| out).map_err(|e| e.to_string())
        };
        let ours = |raw: &[u8]| {
            let mut out = Vec::new();
            Members::new(raw).read_to_end(&mut out).map(|_| out).map_err(|e| e.to_string())
        };
        let data: Vec<u8> = (0..50_000u32).flat_map(|i| format!("v {i} 0 1\n").into_bytes()).collect();
        let mut three = gz(&data);
        three.extend(gz(b""));
        three.extend(gz(b"f 1 2 3\n"));
        let mut damaged = three.clone();
        damaged[40] ^= 0x55;
        for raw in [gz(&data), three.clone(), bgzf(&data), Vec::new(), b"not gzip".to_vec(), three[..three.len() - 3].to_vec(), damaged] {
            assert_eq!(ours(&raw), flate2(&raw));
        }
        assert_eq!(ours(&three).unwrap().len(), data.len() + 8);
    }

    #[test]
    fn gzip_inside_gzip_is_named() {
        let twice = gz(&gz(b"v 0 0 0\n"));
        let (_dir, p) = tmp("double.obj.gz");
        std::fs::write(&p, &twice).unwrap();
        let e = read_file(&p, &ReadLimits::default()).unwrap_err().to_string();
        assert!(e.ends_with("double.obj.gz: the file is compressed twice (gzip inside gzip): decompress it once"), "{e}");
        // Once: read.
        std::fs::write(&p, gz(b"v 0 0 0\n")).unwrap();
        assert_eq!(read_file(&p, &ReadLimits::default()).unwrap(), b"v 0 0 0\n");
    }

    /// `data` as `bgzip` writes it: members of at most 65,280 bytes, each saying its
    /// size, then the format's empty last member.
    fn bgzf(data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        for block in data.chunks(0xff00).chain([&[][..]]) {
            let mut e = flate2::write::DeflateEncoder::new(Vec::new(), flate2::Compression::default());
            e.write_all(block).unwrap();
            let deflated = e.finish().unwrap();
            let len = u16::try_from(18 + deflated.len() + 8 - 1).unwrap();
            out.extend([0x1f, 0x8b, 8, 4, 0, 0, 0, 0, 0, 0xff, 6, 0, b'B', b'C', 2, 0]);
            out.extend(len.to_le_bytes());
            out.extend(deflated);
            let mut crc = flate2::Crc::new();
            crc.update(block);
            out.extend(crc.sum().to_le_bytes());
            out.extend((block.len() as u32).to_le_bytes());
        }
        out
    }

    /// What the one-thread reader makes of `raw`.
    fn serial(raw: &[u8], limits: &ReadLimits) -> std::result::Result<Vec<u8>, String> {
        read_bounded(Path::new("m.gz"), Members::new(raw), 0, limits, "decompresses to").map_err(|e| e.to_string())
    }

    #[test]
    fn bgzf_members_inflate_on_every_thread_to_the_same_bytes() {
        let data: Vec<u8> = (0..300_000u32).flat_map(|i| format!("v {i} {} 0\n", i % 7).into_bytes()).collect();
        let raw = bgzf(&data);
        let members = bgzf_members(&raw).expect("BGZF");
        assert_eq!(members.len(), data.len().div_ceil(0xff00) + 1);
        let limits = ReadLimits::default();
        assert_eq!(inflate_members(&raw, &members, data.len() as u64).as_deref(), Some(&data[..]));
        assert_eq!(gunzip(Path::new("m.gz"), &raw, &limits).unwrap(), data);
        assert_eq!(serial(&raw, &limits).unwrap(), data);
        // Through a file too.
        let (_dir, p) = tmp("m.obj.gz");
        std::fs::write(&p, &raw).unwrap();
        assert_eq!(read_file(&p, &limits).unwrap(), data);
        // Over the limit: the one-thread reader's error (it stops at the limit).
        let e = gunzip(Path::new("m.gz"), &raw, &ReadLimits::new(1 << 20)).unwrap_err().to_string();
        assert!(e.starts_with("m.gz: decompresses to more than the input limit of 1 MiB"), "{e}");
        // Plain gzip, one member or several, is not BGZF.
        assert!(bgzf_members(&gz(&data)).is_none());
        let mut two = gz(b"a\n");
        two.extend(gz(b"b\n"));
        assert!(bgzf_members(&two).is_none());
    }

    #[test]
    fn damaged_bgzf_gets_the_one_thread_readers_answer() {
        let data: Vec<u8> = (0..100_000u32).flat_map(|i| format!("f {i} {} {}\n", i + 1, i + 2).into_bytes()).collect();
        let raw = bgzf(&data);
        let limits = ReadLimits::default();
        let second = bgzf_members(&raw).unwrap()[1].bytes.clone();
        let mut cases = Vec::new();
        // A byte of the second member's deflate data, its CRC, its size; the file cut
        // inside its last member and inside a header.
        for at in [second.start + 30, second.end - 6, second.end - 3] {
            let mut bad = raw.clone();
            bad[at] ^= 0x55;
            cases.push(bad);
        }
        cases.push(raw[..raw.len() - 10].to_vec());
        cases.push(raw[..second.start + 9].to_vec());
        for bad in &cases {
            let ours = gunzip(Path::new("m.gz"), bad, &limits).map_err(|e| e.to_string());
            assert!(ours.is_err());
            assert_eq!(ours, serial(bad, &limits));
        }
        // A wrong size field is nothing to gzip: the one-thread reader reads the file.
        let mut odd = raw.clone();
        odd[second.start + 16] = 0xff;
        odd[second.start + 17] = 0xff;
        assert_eq!(gunzip(Path::new("m.gz"), &odd, &limits).unwrap(), data);
        // A member whose trailer claims more than BGZF allows is not read in parallel.
        let mut big = raw.clone();
        big[second.end - 2] = 2;
        assert!(bgzf_members(&big).is_none());
    }

    #[test]
    fn the_shipped_conference_room_is_bgzf() {
        let raw = include_bytes!("../../data/conference/conference.obj.gz");
        let members = bgzf_members(raw).expect("shipped as BGZF (tools/bgzf.py)");
        assert!(members.len() > 100);
        let limits = ReadLimits::default();
        assert_eq!(gunzip(Path::new("conference.obj.gz"), raw, &limits).unwrap(), serial(raw, &limits).unwrap());
    }

    #[test]
    fn limits_parse_with_units_and_refuse_nonsense() {
        assert_eq!(ReadLimits::parse_max_bytes("1000"), Ok(1000));
        assert_eq!(ReadLimits::parse_max_bytes("4G"), Ok(4 << 30));
        assert_eq!(ReadLimits::parse_max_bytes("512 MiB"), Ok(512 << 20));
        for bad in ["", "abc", "0", "-5", "1.5G", "4X", "99999999999T"] {
            assert!(ReadLimits::parse_max_bytes(bad).is_err(), "{bad}");
        }
        assert_eq!(ReadLimits::from_env_value(None), Ok(ReadLimits::new(1 << 30)));
        assert_eq!(ReadLimits::from_env_value(Some("2M".as_ref())), Ok(ReadLimits::new(2 << 20)));
        let e = ReadLimits::from_env_value(Some("lots".as_ref())).unwrap_err();
        assert!(e.starts_with("ISIR_MAX_INPUT_BYTES='lots': expected a number of bytes"), "{e}");
        assert_eq!(human_bytes(1 << 30), "1 GiB");
        assert_eq!(human_bytes(1000), "1000 bytes");
    }
}
