//! Reading files named by users (`path:` in a pipeline, Nastran INCLUDEs, UFF files).
//!
//! Every such file goes through [`read_input`]: only regular files are read (devices, FIFOs,
//! sockets and directories are refused before any byte is read), at most
//! [`InputPolicy::max_bytes`] bytes are read whatever the file's metadata claims, and with
//! [`InputPolicy::root`] set, only files whose canonical path (symlinks and `..` resolved) lies
//! under that root are read.
//!
//! The policy is process-wide: the CLI sets it once with [`set_policy`]; until then
//! [`policy`] is [`InputPolicy::from_env`], so `FEMU_MAX_INPUT_BYTES` raises or lowers the
//! limit without a flag.
//!
//! The default limit is 2 GiB per import (a deck and all its INCLUDEs together). Production
//! bulk data decks run to hundreds of MB and binary UFF files of thousands of FRFs to a few
//! hundred MB, so 2 GiB admits them with room to spare, while the text is held in memory several
//! times over while parsing (lines, fields), so a limit far above it would let a mistaken path
//! exhaust the memory of a shared machine.
//!
//! Confinement resolves paths when they are opened; a directory under the root that is swapped
//! for a symlink between the check and the open is not detected (use operating-system isolation
//! when the tree itself is writable by untrusted users).

use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::RwLock;

/// Default for [`InputPolicy::max_bytes`]: 2 GiB.
pub const DEFAULT_MAX_INPUT_BYTES: u64 = 2 << 30;

/// Environment variable that sets [`InputPolicy::max_bytes`] (bytes, or with a `K`, `M`, `G`
/// or `T` suffix for powers of 1024).
pub const MAX_INPUT_ENV: &str = "FEMU_MAX_INPUT_BYTES";

/// How user-named files may be read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InputPolicy {
    /// Most bytes read for one import (a file, or a deck with its INCLUDEs).
    pub max_bytes: u64,
    /// When set, only files under this directory are read (compared as canonical paths).
    pub root: Option<PathBuf>,
}

impl Default for InputPolicy {
    fn default() -> Self {
        InputPolicy {
            max_bytes: DEFAULT_MAX_INPUT_BYTES,
            root: None,
        }
    }
}

/// Why a user-named file was not read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum InputError {
    /// The file could not be opened or read.
    #[error("cannot read `{path}`: {message}")]
    Io {
        /// The path as given.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// The path names a device, FIFO, socket or directory.
    #[error("`{path}` is {kind}, not a regular file; femu reads input only from regular files")]
    NotRegular {
        /// The path as given.
        path: String,
        /// What it is instead.
        kind: &'static str,
    },
    /// The file (or the import so far) is larger than the limit.
    #[error(
        "`{path}` is larger than the input limit of {limit} bytes; raise it with {MAX_INPUT_ENV}=<bytes> (e.g. 8G) if the file is meant to be this large"
    )]
    TooLarge {
        /// The path as given.
        path: String,
        /// The limit that applied to this file, bytes.
        limit: u64,
    },
    /// The file lies outside the directory reads are confined to.
    #[error(
        "`{path}` resolves to `{resolved}`, outside `{root}` to which input files are confined"
    )]
    OutsideRoot {
        /// The path as given.
        path: String,
        /// Its canonical form.
        resolved: String,
        /// The root.
        root: String,
    },
    /// The limit in the environment is not a byte count.
    #[error(
        "{MAX_INPUT_ENV} = `{value}` is not a byte count; write a whole number of bytes, optionally with K, M, G or T (powers of 1024), e.g. 4G"
    )]
    BadLimit {
        /// The variable's value (shortened).
        value: String,
    },
}

impl InputPolicy {
    /// The default policy with `FEMU_MAX_INPUT_BYTES` applied when it is set.
    pub fn from_env() -> Result<Self, InputError> {
        let mut p = InputPolicy::default();
        if let Ok(v) = std::env::var(MAX_INPUT_ENV) {
            p.max_bytes = parse_byte_count(&v).ok_or_else(|| InputError::BadLimit {
                value: excerpt(&v, 40),
            })?;
        }
        Ok(p)
    }

    /// This policy with reads confined to `root` (canonicalised now, so it must exist).
    pub fn confined_to(mut self, root: impl AsRef<Path>) -> Result<Self, InputError> {
        let root = root.as_ref();
        let canonical = std::fs::canonicalize(root).map_err(|e| InputError::Io {
            path: root.display().to_string(),
            message: e.to_string(),
        })?;
        self.root = Some(canonical);
        Ok(self)
    }
}

/// Parses `123`, `64K`, `512M`, `2G`, `1T` (optionally with `iB`/`B`: `2GiB`, `2GB`, all powers
/// of 1024). `None` for anything else, zero or an overflow.
pub fn parse_byte_count(text: &str) -> Option<u64> {
    let t = text.trim();
    let digits_end = t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len());
    let (digits, unit) = t.split_at(digits_end);
    let n: u64 = digits.parse().ok()?;
    let unit = unit.trim().to_ascii_uppercase();
    let unit = unit
        .strip_suffix("IB")
        .or_else(|| unit.strip_suffix('B'))
        .unwrap_or(&unit);
    let shift = match unit {
        "" => 0,
        "K" => 10,
        "M" => 20,
        "G" => 30,
        "T" => 40,
        _ => return None,
    };
    n.checked_mul(1u64 << shift).filter(|v| *v > 0)
}

static POLICY: RwLock<Option<InputPolicy>> = RwLock::new(None);

/// Sets the process-wide policy (the CLI does this once, before any stage runs).
pub fn set_policy(policy: InputPolicy) {
    let mut guard = POLICY.write().unwrap_or_else(|e| e.into_inner());
    *guard = Some(policy);
}

/// The process-wide policy: the one set by [`set_policy`], else [`InputPolicy::from_env`].
pub fn policy() -> Result<InputPolicy, InputError> {
    let guard = POLICY.read().unwrap_or_else(|e| e.into_inner());
    match guard.as_ref() {
        Some(p) => Ok(p.clone()),
        None => InputPolicy::from_env(),
    }
}

/// Reads a user-named file under the process-wide [`policy`].
pub fn read_input(path: &Path) -> Result<Vec<u8>, InputError> {
    let p = policy()?;
    read_input_with(path, &p, p.max_bytes)
}

/// Reads a user-named file under `policy`, at most `limit` bytes (≤ the policy's limit; an
/// import that reads several files passes what is left of its budget).
pub fn read_input_with(
    path: &Path,
    policy: &InputPolicy,
    limit: u64,
) -> Result<Vec<u8>, InputError> {
    let shown = path.display().to_string();
    let io = |e: std::io::Error| InputError::Io {
        path: shown.clone(),
        message: e.to_string(),
    };
    let limit = limit.min(policy.max_bytes);
    let target = match &policy.root {
        None => path.to_path_buf(),
        Some(root) => {
            let resolved = std::fs::canonicalize(path).map_err(io)?;
            if !resolved.starts_with(root) {
                return Err(InputError::OutsideRoot {
                    path: shown,
                    resolved: resolved.display().to_string(),
                    root: root.display().to_string(),
                });
            }
            resolved
        }
    };
    // `stat` first: opening a FIFO would block and opening a device may have effects.
    let meta = std::fs::metadata(&target).map_err(io)?;
    check_regular(&shown, &meta)?;
    let file = open_nonblocking(&target).map_err(io)?;
    // The file may have been swapped since `stat`: check what was opened.
    let meta = file.metadata().map_err(io)?;
    check_regular(&shown, &meta)?;
    if meta.len() > limit {
        return Err(InputError::TooLarge { path: shown, limit });
    }
    // The length is a hint only (files grow, some file systems report 0): read at most
    // `limit + 1` bytes, so one byte too many is seen without reading the rest.
    let hint = usize::try_from(meta.len()).unwrap_or(0);
    let mut buf = Vec::with_capacity(hint.saturating_add(1));
    file.take(limit.saturating_add(1))
        .read_to_end(&mut buf)
        .map_err(io)?;
    if buf.len() as u64 > limit {
        return Err(InputError::TooLarge { path: shown, limit });
    }
    Ok(buf)
}

fn check_regular(path: &str, meta: &std::fs::Metadata) -> Result<(), InputError> {
    let ft = meta.file_type();
    if ft.is_file() {
        return Ok(());
    }
    let kind = if ft.is_dir() {
        "a directory"
    } else {
        special_kind(&ft)
    };
    Err(InputError::NotRegular {
        path: path.to_string(),
        kind,
    })
}

#[cfg(unix)]
fn special_kind(ft: &std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if ft.is_char_device() {
        "a character device"
    } else if ft.is_block_device() {
        "a block device"
    } else if ft.is_fifo() {
        "a FIFO (named pipe)"
    } else if ft.is_socket() {
        "a socket"
    } else {
        "a special file"
    }
}

#[cfg(not(unix))]
fn special_kind(_: &std::fs::FileType) -> &'static str {
    "a special file"
}

#[cfg(unix)]
fn open_nonblocking(path: &Path) -> std::io::Result<std::fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
}

#[cfg(not(unix))]
fn open_nonblocking(path: &Path) -> std::io::Result<std::fs::File> {
    std::fs::File::open(path)
}

/// At most `max` characters of `s` (trimmed, cut on a character boundary, `…` when cut), with
/// control characters shown as `?`, for quoting user text in messages.
pub fn excerpt(s: &str, max: usize) -> String {
    let s = s.trim();
    let mut out: String = s
        .chars()
        .take(max)
        .map(|c| if c.is_control() { '?' } else { c })
        .collect();
    if s.chars().nth(max).is_some() {
        out.push('…');
    }
    out
}

/// Characters quoted from an offending line in import messages.
pub const EXCERPT_CHARS: usize = 40;

#[cfg(test)]
mod tests {
    use super::*;

    fn policy_of(max: u64) -> InputPolicy {
        InputPolicy {
            max_bytes: max,
            root: None,
        }
    }

    #[test]
    fn byte_counts_with_suffixes() {
        assert_eq!(parse_byte_count("123"), Some(123));
        assert_eq!(parse_byte_count("64K"), Some(64 << 10));
        assert_eq!(parse_byte_count("512m"), Some(512 << 20));
        assert_eq!(parse_byte_count(" 2GiB "), Some(2 << 30));
        assert_eq!(parse_byte_count("1TB"), Some(1 << 40));
        for bad in ["", "0", "-1", "1.5G", "12X", "G", "99999999999999999999T"] {
            assert_eq!(parse_byte_count(bad), None, "{bad}");
        }
    }

    #[test]
    fn devices_fifos_and_directories_are_refused_before_reading() {
        let p = InputPolicy::default();
        for dev in ["/dev/zero", "/dev/urandom", "/dev/null"] {
            let e = read_input_with(Path::new(dev), &p, p.max_bytes).unwrap_err();
            assert!(
                matches!(
                    e,
                    InputError::NotRegular {
                        kind: "a character device",
                        ..
                    }
                ),
                "{e}"
            );
            assert!(e.to_string().contains("not a regular file"), "{e}");
        }
        let dir = tempfile::tempdir().unwrap();
        let e = read_input_with(dir.path(), &p, p.max_bytes).unwrap_err();
        assert!(
            matches!(
                e,
                InputError::NotRegular {
                    kind: "a directory",
                    ..
                }
            ),
            "{e}"
        );
        #[cfg(unix)]
        {
            let fifo = dir.path().join("fifo");
            let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
            // SAFETY: a valid NUL-terminated path.
            assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
            // Without the check this would block for ever on open.
            let e = read_input_with(&fifo, &p, p.max_bytes).unwrap_err();
            assert!(
                matches!(
                    e,
                    InputError::NotRegular {
                        kind: "a FIFO (named pipe)",
                        ..
                    }
                ),
                "{e}"
            );
        }
    }

    #[test]
    fn the_limit_is_exact_and_counted_in_bytes_read() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("f.txt");
        std::fs::write(&f, vec![b'x'; 100]).unwrap();
        assert_eq!(
            read_input_with(&f, &policy_of(100), 100).unwrap().len(),
            100
        );
        let e = read_input_with(&f, &policy_of(99), 99).unwrap_err();
        assert_eq!(
            e,
            InputError::TooLarge {
                path: f.display().to_string(),
                limit: 99
            }
        );
        assert!(e.to_string().contains(MAX_INPUT_ENV), "{e}");
        // The budget passed in is capped by the policy and vice versa.
        assert!(read_input_with(&f, &policy_of(1000), 50).is_err());
        assert!(read_input_with(&f, &policy_of(50), 1000).is_err());
        // /proc files report length 0 but have content: the reader does not trust the length.
        let status = Path::new("/proc/self/status");
        if status.exists() {
            let whole = read_input_with(status, &policy_of(1 << 20), 1 << 20).unwrap();
            assert!(whole.len() > 10);
            assert!(matches!(
                read_input_with(status, &policy_of(10), 10),
                Err(InputError::TooLarge { limit: 10, .. })
            ));
        }
    }

    #[cfg(unix)]
    #[test]
    fn confinement_follows_dot_dot_and_symlinks() {
        let outer = tempfile::tempdir().unwrap();
        let root = outer.path().join("tree");
        std::fs::create_dir_all(root.join("sub")).unwrap();
        std::fs::write(root.join("sub/in.bdf"), "GRID,1\n").unwrap();
        std::fs::write(outer.path().join("secret.txt"), "secret\n").unwrap();
        std::os::unix::fs::symlink(outer.path().join("secret.txt"), root.join("link.txt")).unwrap();
        std::os::unix::fs::symlink(root.join("sub/in.bdf"), root.join("inner_link.bdf")).unwrap();
        let p = InputPolicy::default().confined_to(&root).unwrap();
        let ok = |rel: &str| read_input_with(&root.join(rel), &p, p.max_bytes);
        assert_eq!(ok("sub/in.bdf").unwrap(), b"GRID,1\n");
        assert_eq!(ok("sub/../sub/in.bdf").unwrap(), b"GRID,1\n");
        assert_eq!(ok("inner_link.bdf").unwrap(), b"GRID,1\n");
        for escape in ["../secret.txt", "sub/../../secret.txt", "link.txt"] {
            let e = ok(escape).unwrap_err();
            assert!(matches!(e, InputError::OutsideRoot { .. }), "{escape}: {e}");
            assert!(!e.to_string().contains("secret\n"));
        }
        // Without confinement, `../` reads are a feature.
        let free = InputPolicy::default();
        assert!(read_input_with(&root.join("../secret.txt"), &free, free.max_bytes).is_ok());
    }

    #[test]
    fn the_process_wide_policy_is_set_once_and_read_back() {
        // The only test that touches the global; it restores the default afterwards.
        let before = policy().unwrap();
        let set = InputPolicy {
            max_bytes: 3 << 30,
            root: Some(PathBuf::from("/")),
        };
        set_policy(set.clone());
        assert_eq!(policy().unwrap(), set);
        set_policy(before.clone());
        assert_eq!(policy().unwrap(), before);
    }

    #[test]
    fn excerpts_are_short_and_cut_on_char_boundaries() {
        assert_eq!(excerpt("  GRID  ", 40), "GRID");
        let long = "é".repeat(50);
        let e = excerpt(&long, 40);
        assert_eq!(e.chars().count(), 41);
        assert!(e.ends_with('…'));
        assert_eq!(excerpt("a\u{7}b", 40), "a?b");
        assert_eq!(excerpt(&"x".repeat(40), 40), "x".repeat(40));
    }
}
