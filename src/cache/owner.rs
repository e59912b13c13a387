//! Owners of temporaries. Every temporary name ends in `.<pid>@<host>`, so a later process can
//! tell the work of a process that died (`kill -9`, a node crash) from the work of one that is
//! still running, and remove the former at once instead of waiting for `femu cache gc`.
//!
//! The host tag is the host name plus, on Linux, the PID namespace: two containers that share a
//! host name but not their process IDs do not judge each other's processes.

use std::sync::OnceLock;

/// This machine's host name: the kernel's, else `$HOSTNAME`, else `localhost` (a name that
/// is empty or holds white space does not count, so that it stays one word in a lock file).
pub fn host_name() -> String {
    let usable = |s: String| {
        let s = s.trim();
        (!s.is_empty() && !s.contains(char::is_whitespace)).then(|| s.to_string())
    };
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .and_then(usable)
        .or_else(|| std::env::var("HOSTNAME").ok().and_then(usable))
        .unwrap_or_else(|| "localhost".into())
}

/// This machine's tag: the host name (letters, digits and `-` only) and its PID namespace.
pub fn host_tag() -> &'static str {
    static TAG: OnceLock<String> = OnceLock::new();
    TAG.get_or_init(|| {
        let mut tag: String = host_name()
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        // `pid:[4026531836]` on Linux: the namespace's inode.
        if let Ok(ns) = std::fs::read_link("/proc/self/ns/pid") {
            let digits: String = ns
                .to_string_lossy()
                .chars()
                .filter(char::is_ascii_digit)
                .collect();
            if !digits.is_empty() {
                tag.push_str("-ns");
                tag.push_str(&digits);
            }
        }
        tag
    })
}

/// The suffix that marks a temporary of process `pid` on this host.
pub fn owner_suffix(pid: u32) -> String {
    format!("{pid}@{}", host_tag())
}

/// The process and host tag of a temporary named `<anything>.<pid>@<host>`.
pub fn parse_owner(name: &str) -> Option<(u32, &str)> {
    let (front, host) = name.rsplit_once('@')?;
    let (_, pid) = front.rsplit_once('.')?;
    Some((pid.parse().ok()?, host))
}

/// Whether `pid` is known to be dead on this host: `kill(pid, 0)` fails with `ESRCH`. Any doubt
/// (permission denied, a zombie, another platform) counts as alive.
pub fn process_is_dead(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Ok(p) = libc::pid_t::try_from(pid) else {
            return false;
        };
        if p <= 0 {
            return false;
        }
        // SAFETY: signal 0 performs only the existence and permission checks; nothing is sent.
        let r = unsafe { libc::kill(p, 0) };
        r == -1 && std::io::Error::last_os_error().raw_os_error() == Some(libc::ESRCH)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        false
    }
}

/// Whether the temporary `name` was left by a process of this host that has died.
pub fn is_stale(name: &str) -> bool {
    parse_owner(name).is_some_and(|(pid, host)| {
        host == host_tag() && pid != std::process::id() && process_is_dead(pid)
    })
}

/// The pid of a child process that has already exited (and been reaped), for tests of what
/// happens to a dead process's leftovers.
#[cfg(test)]
pub(crate) fn exited_child_pid() -> u32 {
    let mut child = std::process::Command::new("sh")
        .args(["-c", "exit 0"])
        .spawn()
        .expect("sh runs");
    let pid = child.id();
    child.wait().expect("the child exits");
    pid
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn owners_parse_and_only_dead_local_processes_are_stale() {
        let me = std::process::id();
        let name = format!("abc.3.17.{}", owner_suffix(me));
        assert_eq!(parse_owner(&name), Some((me, host_tag())));
        assert!(!is_stale(&name), "this process is alive");
        assert_eq!(parse_owner("abc.12.7"), None, "old names have no owner");
        let dead = exited_child_pid();
        assert!(process_is_dead(dead));
        assert!(is_stale(&format!("k.0.0.{}", owner_suffix(dead))));
        assert!(!is_stale(&format!("k.0.0.{dead}@another-host")));
        assert!(!process_is_dead(0) && !process_is_dead(u32::MAX));
    }
}
