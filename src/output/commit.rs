//! The output-commit layer: every output of a run is planned before any work, rendered
//! into a temporary file, and committed together with the others only when all rendered.
//!
//! How it works:
//! - [`OutputSet::plan`] checks each output before any work. A symlink is followed to its
//!   target (the rename replaces the target, the link stays). A directory, a missing or
//!   unwritable directory, a block device or a socket is refused. An output that is the
//!   same file (device and inode) as an input (the model, an environment file, a hard
//!   link or a symlink to either) is refused, as are two outputs that are one file. A FIFO,
//!   a character device (`/dev/null`) or anything under `/dev/` or `/proc/`
//!   (`/dev/stdout`) is *special*: it is written directly, never renamed over, and last.
//!   Each output gets its temporary file at once (so an unwritable place fails now), named
//!   `.detune-<host>-<pid>-<random>.tmp` next to its target (in the system's temporary
//!   directory for a special output). Stale temporary files of this host whose process is
//!   dead (`kill(pid, 0)` → `ESRCH`) or older than 24 h are removed from those
//!   directories; a live run's never (shards run side by side in one directory).
//! - While the set is planned, [`super::write_atomic`] on one of its paths renders into
//!   that output's temporary file instead of writing the target.
//! - [`OutputSet::commit`] renames the regular outputs into place in the order given
//!   (an existing target is first hard-linked to a backup so a failure later in the
//!   commit can restore it), then copies the special ones. If any step fails, the outputs
//!   already committed are rolled back (restored or removed) and nothing is left.
//! - Dropping a set that was not committed (an error, an interruption) removes its
//!   temporary files. Every temporary file is also listed in a fixed table of atomic
//!   pointers that a signal handler may read: [`remove_temps_now`] unlinks them with
//!   async-signal-safe calls only, so a signal that ends the process leaves no temporary
//!   file either. (SIGKILL cannot be caught; its temporary files are stale for the next
//!   run, which removes them.)
//!
//! Written by hand: `tempfile` makes the temporary files; no crate commits a set of files
//! together or knows of special files and process-tagged temporary names.

use crate::diag::{Error, Result};
use std::ffi::CString;
use std::fs::{File, OpenOptions};
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicPtr, Ordering};

/// How old a stale temporary file of a live process id must be before it is removed
/// (the id may have been reused): 24 h.
const STALE_AGE: std::time::Duration = std::time::Duration::from_secs(24 * 3600);

/// This host's name as it goes into temporary-file names (characters other than
/// letters, digits, `.` and `_` become `_`, so the name parses back).
pub fn host() -> &'static str {
    static HOST: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    HOST.get_or_init(|| {
        #[cfg(unix)]
        let raw = {
            let mut buf = [0u8; 256];
            // SAFETY: gethostname writes at most buf.len() bytes into buf.
            let ok = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) } == 0;
            let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
            if ok {
                String::from_utf8_lossy(&buf[..end]).into_owned()
            } else {
                String::new()
            }
        };
        #[cfg(not(unix))]
        let raw = std::env::var("COMPUTERNAME").unwrap_or_default();
        let h: String = raw
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '.' || c == '_' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        if h.is_empty() { "host".into() } else { h }
    })
}

/// The prefix of this process's temporary files: `.detune-<host>-<pid>-`.
pub fn temp_prefix() -> String {
    format!(".detune-{}-{}-", host(), std::process::id())
}

/// The host and process id in a temporary file's name `.detune-<host>-<pid>-<random>.tmp`.
pub fn parse_temp_name(name: &str) -> Option<(&str, u32)> {
    let rest = name.strip_prefix(".detune-")?.strip_suffix(".tmp")?;
    let (rest, _random) = rest.rsplit_once('-')?;
    let (host, pid) = rest.rsplit_once('-')?;
    Some((host, pid.parse().ok()?))
}

/// Is process `pid` alive on this host? (`kill(pid, 0)`: only `ESRCH` means dead.)
fn alive(pid: u32) -> bool {
    #[cfg(unix)]
    {
        let Ok(pid) = libc::pid_t::try_from(pid) else {
            return false;
        };
        // SAFETY: signal 0 only checks that the process exists.
        let r = unsafe { libc::kill(pid, 0) };
        r == 0 || std::io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH)
    }
    #[cfg(not(unix))]
    {
        let _ = pid;
        true
    }
}

/// Remove the stale temporary files in `dir`: this host's, whose process is dead or
/// which are older than 24 h. Returns how many were removed. Other hosts' files and a
/// live run's are left alone.
pub fn remove_stale_temps(dir: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let own = std::process::id();
    let mut removed = 0;
    for e in entries.flatten() {
        let name = e.file_name();
        let Some((h, pid)) = name.to_str().and_then(parse_temp_name) else {
            continue;
        };
        if h != host() || pid == own {
            continue;
        }
        let old = e
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok())
            .is_some_and(|age| age > STALE_AGE);
        if (old || !alive(pid)) && std::fs::remove_file(e.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

// ---- the temporary files a signal handler may remove ----

const SLOTS: usize = 64;
/// Paths (leaked C strings) of this process's temporary files; null for a free slot.
/// Whoever swaps a pointer out owns it: the handler unlinks it, the owner frees it.
static TEMP_SLOTS: [AtomicPtr<libc::c_char>; SLOTS] =
    [const { AtomicPtr::new(std::ptr::null_mut()) }; SLOTS];

fn register(path: &Path) -> Option<usize> {
    use std::os::unix::ffi::OsStrExt;
    let c = CString::new(path.as_os_str().as_bytes()).ok()?.into_raw();
    for (i, slot) in TEMP_SLOTS.iter().enumerate() {
        if slot
            .compare_exchange(std::ptr::null_mut(), c, Ordering::SeqCst, Ordering::SeqCst)
            .is_ok()
        {
            return Some(i);
        }
    }
    // SAFETY: `c` came from into_raw above and was not stored.
    drop(unsafe { CString::from_raw(c) });
    None
}

fn unregister(slot: usize) {
    let p = TEMP_SLOTS[slot].swap(std::ptr::null_mut(), Ordering::SeqCst);
    if !p.is_null() {
        // SAFETY: `p` came from CString::into_raw in `register`; the swap made it ours.
        drop(unsafe { CString::from_raw(p) });
    }
}

/// Unlink every temporary file of this process. Async-signal-safe (atomic swaps and
/// `unlink` only): for a signal handler about to end the process.
pub fn remove_temps_now() {
    for slot in &TEMP_SLOTS {
        let p = slot.swap(std::ptr::null_mut(), Ordering::SeqCst);
        if !p.is_null() {
            // SAFETY: `p` is a NUL-terminated path; it is leaked, never freed, here.
            unsafe { libc::unlink(p) };
        }
    }
}

/// A temporary file of this process: registered for the signal handler, removed on drop
/// unless [`Temp::keep`] took it.
struct Temp {
    path: PathBuf,
    file: Option<File>,
    slot: Option<usize>,
}

impl Temp {
    /// A new temporary file in `dir`, mode 0644.
    fn create(dir: &Path) -> std::io::Result<Temp> {
        let named = tempfile::Builder::new()
            .prefix(&temp_prefix())
            .suffix(".tmp")
            .rand_bytes(8)
            .permissions(std::fs::Permissions::from_mode(0o644))
            .tempfile_in(dir)?;
        let (file, path) = named.keep().map_err(|e| e.error)?;
        let slot = register(&path);
        Ok(Temp {
            path,
            file: Some(file),
            slot,
        })
    }

    /// The path no longer names a temporary file (it was renamed into place).
    fn keep(mut self) {
        if let Some(s) = self.slot.take() {
            unregister(s);
        }
        self.file = None;
        self.path = PathBuf::new();
    }
}

use std::os::unix::fs::PermissionsExt;

impl Drop for Temp {
    fn drop(&mut self) {
        self.file = None;
        if !self.path.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.path);
        }
        if let Some(s) = self.slot.take() {
            unregister(s);
        }
    }
}

/// One planned output.
struct Planned {
    /// The path as given (how `write_atomic` names it, how messages name it).
    given: String,
    /// Where the content goes: the symlink's final target for a regular file.
    target: PathBuf,
    /// Written directly, never renamed over, last (FIFO, character device, `/dev/...`).
    special: bool,
    /// The rendered content, until committed; `None` while rendering.
    temp: Option<Temp>,
    /// Rendered at least once (an output never rendered is not written).
    rendered: bool,
}

/// The planned sets, innermost last: `write_atomic` renders into the innermost set that
/// names the path.
static ACTIVE: Mutex<Vec<(u64, Vec<Planned>)>> = Mutex::new(Vec::new());
static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

fn active() -> std::sync::MutexGuard<'static, Vec<(u64, Vec<Planned>)>> {
    ACTIVE.lock().unwrap_or_else(|e| e.into_inner())
}

/// A run's planned outputs: created by [`OutputSet::plan`] before any work, committed
/// all together by [`OutputSet::commit`]; dropped uncommitted, it removes its temporary
/// files and writes nothing.
#[must_use = "outputs are only written by OutputSet::commit"]
pub struct OutputSet {
    id: u64,
}

/// Follow `p` through symlinks (relative ones from their directory) to a path that is
/// not a symlink (it may not exist). More than 40 links is a loop.
fn resolve_links(given: &str) -> Result<PathBuf> {
    let mut p = PathBuf::from(given);
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let t = std::fs::read_link(&p).map_err(|e| Error::io(given, e))?;
                p = if t.is_absolute() {
                    t
                } else {
                    parent_dir(&p).join(t)
                };
            }
            _ => return Ok(p),
        }
    }
    Err(Error::request(
        format!("{given}: too many levels of symbolic links"),
        "point the output at a file, not a loop of links",
    ))
}

/// Whether `a` and `b` name the same file, as the outputs are compared with the inputs
/// and with each other: the same device and inode when both exist (symlinks followed:
/// `./x`, `x`, a link to it, a hard link), else the same absolute path once the
/// directory is canonicalized (`./new.ckpt` and `new.ckpt`). A path that exists and one
/// that does not are different files.
pub fn same_file(a: &str, b: &str) -> bool {
    if a == b {
        return true;
    }
    let (pa, pb) = (Path::new(a), Path::new(b));
    match (file_id(pa), file_id(pb)) {
        (Some(x), Some(y)) => x == y,
        (None, None) => normalized(pa) == normalized(pb),
        _ => false,
    }
}

/// `p` absolute, its directory canonicalized where it exists.
fn normalized(p: &Path) -> PathBuf {
    let dir = parent_dir(p);
    let dir = dir
        .canonicalize()
        .or_else(|_| std::path::absolute(&dir))
        .unwrap_or(dir);
    dir.join(p.file_name().unwrap_or_default())
}

/// The directory of `p` (`.` for a bare file name).
fn parent_dir(p: &Path) -> PathBuf {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Whether `path` names this process's standard output (`/dev/stdout`, `/dev/fd/1`,
/// `/proc/self/fd/1`), written through it at commit: a command writing an output there
/// prints its own text elsewhere (on stderr), as `draw -o /dev/stdout` does.
pub fn is_stdout(path: &str) -> bool {
    ["/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"]
        .iter()
        .any(|n| Path::new(path) == Path::new(n))
}

/// Whether `path` is a special file an output is streamed into (a device such as
/// `/dev/stdout`, or an existing FIFO, socket or device): not a regular file or a name to
/// create.
pub fn is_stream(path: &str) -> bool {
    path.starts_with("/dev/") || std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// A file's identity: (device, inode).
type FileId = (u64, u64);

/// (device, inode) of an existing file, symlinks followed.
fn file_id(p: &Path) -> Option<FileId> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
}

/// Can this process write `p`? (`access(W_OK)`.)
fn writable(p: &Path) -> bool {
    use std::os::unix::ffi::OsStrExt;
    let Ok(c) = CString::new(p.as_os_str().as_bytes()) else {
        return false;
    };
    // SAFETY: `c` is a valid NUL-terminated path.
    unsafe { libc::access(c.as_ptr(), libc::W_OK) == 0 }
}

fn plan_one(given: &str) -> Result<Planned> {
    use std::os::unix::fs::FileTypeExt;
    if given.is_empty() {
        return Err(Error::request(
            "an empty output file name",
            "give a file name, e.g. out.csv",
        ));
    }
    let in_dev = |p: &Path| {
        [Path::new("/dev"), Path::new("/proc")]
            .iter()
            .any(|d| p.starts_with(d))
    };
    // `/dev/stdout` is written as itself (its link may point at `pipe:[…]`)
    let target = if in_dev(Path::new(given)) {
        PathBuf::from(given)
    } else {
        resolve_links(given)?
    };
    let meta = std::fs::metadata(&target).ok();
    let under_dev = in_dev(&target);
    let special = match &meta {
        Some(m) if m.is_dir() => {
            return Err(Error::request(
                format!("{given}: is a directory, not a file name"),
                "give a file name, e.g. out.csv",
            ));
        }
        Some(m) if m.file_type().is_block_device() || m.file_type().is_socket() => {
            return Err(Error::request(
                format!(
                    "{given}: is a {}, not a file",
                    if m.file_type().is_socket() {
                        "socket"
                    } else {
                        "block device"
                    }
                ),
                "write the output to a file, a pipe or /dev/null",
            ));
        }
        Some(m) => m.file_type().is_fifo() || m.file_type().is_char_device() || under_dev,
        None => under_dev,
    };
    if target.file_name().is_none() || given.ends_with('/') {
        return Err(Error::request(
            format!("{given}: is a directory, not a file name"),
            "give a file name, e.g. out.csv",
        ));
    }
    let temp = if special {
        if meta.is_none() {
            return Err(Error::request(
                format!("{given}: no such device"),
                "write the output to a file, a pipe or /dev/null",
            ));
        }
        if !writable(&target) {
            return Err(Error::request(
                format!("{given}: not writable by this user"),
                "write the output elsewhere",
            ));
        }
        let dir = std::env::temp_dir();
        remove_stale_temps(&dir);
        Temp::create(&dir).map_err(|e| {
            Error::io(
                given,
                format!("cannot create a temporary file in {}: {e}", dir.display()),
            )
        })?
    } else {
        let dir = parent_dir(&target);
        if !dir.is_dir() {
            return Err(Error::request(
                format!("{given}: the directory {} does not exist", dir.display()),
                "create it first, or write the output elsewhere",
            ));
        }
        if meta.is_some() && !writable(&target) {
            return Err(Error::request(
                format!("{given}: not writable by this user"),
                "write the output elsewhere, or change the file's permissions",
            ));
        }
        remove_stale_temps(&dir);
        Temp::create(&dir).map_err(|e| {
            Error::io(
                given,
                format!("cannot create a file in {}: {e}", dir.display()),
            )
        })?
    };
    Ok(Planned {
        given: given.to_string(),
        target,
        special,
        temp: Some(temp),
        rendered: false,
    })
}

impl OutputSet {
    /// Plan `outputs` (`None`s skipped) of a run that reads `inputs`, each `(what, path)`
    /// as in `("model file", "models/inceptor.toml")`: check each output (see the module
    /// doc) and make its temporary file, before any work.
    pub fn plan(inputs: &[(&str, &str)], outputs: &[Option<&str>]) -> Result<OutputSet> {
        let input_ids: Vec<(&str, &str, FileId)> = inputs
            .iter()
            .filter_map(|(what, i)| file_id(Path::new(i)).map(|id| (*what, *i, id)))
            .collect();
        let mut planned: Vec<Planned> = Vec::new();
        // identities of the regular outputs so far: (dev, ino) when the file exists, else
        // the canonical directory and the name
        let mut seen: Vec<(Option<FileId>, PathBuf, String)> = Vec::new();
        for given in outputs.iter().flatten() {
            let p = plan_one(given)?;
            if !p.special {
                let id = file_id(&p.target);
                if let Some(id) = id
                    && let Some((what, input, _)) = input_ids.iter().find(|(_, _, i)| *i == id)
                {
                    return Err(Error::request(
                        format!(
                            "{given}: this would overwrite the {what} {input} (the same file, or a link to it)"
                        ),
                        "give the output another name",
                    ));
                }
                let dir = parent_dir(&p.target);
                let dir = dir.canonicalize().unwrap_or(dir);
                let key = dir.join(p.target.file_name().unwrap_or_default());
                if let Some((_, _, other)) = seen
                    .iter()
                    .find(|(i, k, _)| (id.is_some() && *i == id) || *k == key)
                {
                    return Err(Error::request(
                        format!("{given}: the same file as the output {other}"),
                        "give each output its own name",
                    ));
                }
                seen.push((id, key, given.to_string()));
            }
            planned.push(p);
        }
        let id = NEXT_ID.fetch_add(1, Ordering::SeqCst);
        active().push((id, planned));
        Ok(OutputSet { id })
    }

    /// Take this set's entries out of the active list.
    fn take(&self) -> Vec<Planned> {
        let mut a = active();
        match a.iter().position(|(i, _)| *i == self.id) {
            Some(k) => a.remove(k).1,
            None => Vec::new(),
        }
    }

    /// Put every rendered output in place: the regular ones renamed, in the order given,
    /// then the special ones written. On a failure the outputs already committed are
    /// rolled back and every temporary file removed: all or none.
    pub fn commit(self) -> Result<()> {
        let mut planned = self.take();
        planned.retain(|p| p.rendered);
        // regular first, special last (stable: each group in the order given)
        planned.sort_by_key(|p| p.special);
        // (target, backup of what it replaced) of each output committed so far
        let mut done: Vec<(PathBuf, Option<Temp>)> = Vec::new();
        let mut failure = None;
        for p in &mut planned {
            let Some(temp) = p.temp.take() else { continue };
            let r = if p.special {
                copy_into_special(&temp.path, &p.target)
            } else {
                let backup = backup_of(&p.target);
                let r = std::fs::rename(&temp.path, &p.target);
                if r.is_ok() {
                    temp.keep();
                    done.push((p.target.clone(), backup));
                }
                r
            };
            if let Err(e) = r {
                failure = Some(Error::io(&p.given, e));
                break;
            }
        }
        match failure {
            None => Ok(()),
            Some(e) => {
                for (target, backup) in done.into_iter().rev() {
                    match backup {
                        Some(b) => {
                            if std::fs::rename(&b.path, &target).is_ok() {
                                b.keep();
                            }
                        }
                        None => {
                            let _ = std::fs::remove_file(&target);
                        }
                    }
                }
                Err(e)
            }
        }
    }
}

/// A hard link to an existing `target` under a temporary name, to restore it if the
/// commit fails later (`None` if there is nothing to keep or no link can be made).
fn backup_of(target: &Path) -> Option<Temp> {
    if !target.is_file() {
        return None;
    }
    let dir = parent_dir(target);
    for _ in 0..4 {
        let name = format!("{}{:016x}.tmp", temp_prefix(), rand_u64());
        let path = dir.join(name);
        if std::fs::hard_link(target, &path).is_ok() {
            let slot = register(&path);
            return Some(Temp {
                path,
                file: None,
                slot,
            });
        }
    }
    None
}

fn rand_u64() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0),
    );
    h.finish()
}

/// Set while a special output (a FIFO, a device) is being opened or written: `open` on a
/// FIFO blocks until a reader appears, and a write to one blocks while its reader does
/// not read. A signal handler that would otherwise only set a flag for the run to poll
/// (the run is past its polling by then) ends the process at once while this is set
/// (see [`writing_special`]).
static WRITING_SPECIAL: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether this process is opening or writing a special output (FIFO, device), where it
/// may block for good (a FIFO with no reader). Async-signal-safe (an atomic load): for a
/// signal handler deciding to end the process at once.
pub fn writing_special() -> bool {
    WRITING_SPECIAL.load(Ordering::SeqCst)
}

/// [`copy_into`] with [`writing_special`] set meanwhile.
fn copy_into_special(from: &Path, to: &Path) -> std::io::Result<()> {
    WRITING_SPECIAL.store(true, Ordering::SeqCst);
    let r = copy_into(from, to);
    WRITING_SPECIAL.store(false, Ordering::SeqCst);
    r
}

/// Write a special file (FIFO, device) from the rendered temporary file: opened for
/// writing without truncation or creation.
/// `/dev/stdout` and `/dev/stderr` are this process's own streams, written through them
/// (opened anew, a redirected file would be written from its start, over the rest).
fn copy_into(from: &Path, to: &Path) -> std::io::Result<()> {
    let mut src = File::open(from)?;
    let own = |names: &[&str]| names.iter().any(|n| to == Path::new(n));
    if own(&["/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"]) {
        let mut out = std::io::stdout().lock();
        std::io::copy(&mut src, &mut out)?;
        return out.flush();
    }
    if own(&["/dev/stderr", "/dev/fd/2", "/proc/self/fd/2"]) {
        let mut err = std::io::stderr().lock();
        std::io::copy(&mut src, &mut err)?;
        return err.flush();
    }
    let mut dst = OpenOptions::new().write(true).open(to)?;
    std::io::copy(&mut src, &mut dst)?;
    dst.flush()
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        // an uncommitted set: its temporary files go with its entries
        drop(self.take());
    }
}

/// Render `path` with `fill`: into its temporary file if a planned set names it (the
/// set's commit puts it in place), else planned, rendered and committed on its own.
pub fn render(path: &str, fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> Result<()> {
    // the innermost set that names the path lends its temporary file while rendering
    let lent = {
        let mut a = active();
        a.iter_mut().rev().find_map(|(id, set)| {
            set.iter_mut()
                .find(|p| p.given == path)
                .and_then(|p| p.temp.take().map(|t| (*id, t)))
        })
    };
    let Some((id, mut temp)) = lent else {
        let set = OutputSet::plan(&[], &[Some(path)])?;
        render(path, fill)?;
        return set.commit();
    };
    let result = fill_temp(&mut temp, path, fill);
    let mut a = active();
    if let Some((_, set)) = a.iter_mut().find(|(i, _)| *i == id)
        && let Some(p) = set.iter_mut().find(|p| p.given == path)
    {
        p.temp = Some(temp);
        p.rendered = result.is_ok();
    }
    result
}

fn fill_temp(
    temp: &mut Temp,
    path: &str,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let file = match temp.file.as_mut() {
        Some(f) => f,
        None => {
            temp.file = Some(
                OpenOptions::new()
                    .write(true)
                    .open(&temp.path)
                    .map_err(|e| Error::io(path, e))?,
            );
            temp.file.as_mut().expect("just set")
        }
    };
    // a second rendering of the same output replaces the first
    file.set_len(0).map_err(|e| Error::io(path, e))?;
    file.rewind().map_err(|e| Error::io(path, e))?;
    let mut w = std::io::BufWriter::new(file);
    fill(&mut w).map_err(|e| Error::io(path, e))?;
    w.flush().map_err(|e| Error::io(path, e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temp_names_parse_back() {
        let name = format!("{}abc123.tmp", temp_prefix());
        assert_eq!(parse_temp_name(&name), Some((host(), std::process::id())));
        assert_eq!(
            parse_temp_name(".detune-my_host.x-42-zz.tmp"),
            Some(("my_host.x", 42))
        );
        assert_eq!(parse_temp_name(".detune-h-notapid-zz.tmp"), None);
        assert_eq!(parse_temp_name("detune-h-1-zz.tmp"), None);
    }

    #[test]
    fn an_uncommitted_set_leaves_nothing_and_a_committed_one_everything() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.txt");
        let b = dir.path().join("b.txt");
        let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
        {
            let set = OutputSet::plan(&[], &[Some(a), Some(b)]).unwrap();
            render(a, |w| w.write_all(b"A")).unwrap();
            drop(set);
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let set = OutputSet::plan(&[], &[Some(a), Some(b)]).unwrap();
        render(a, |w| w.write_all(b"A")).unwrap();
        render(b, |w| w.write_all(b"B")).unwrap();
        set.commit().unwrap();
        assert_eq!(std::fs::read_to_string(a).unwrap(), "A");
        assert_eq!(std::fs::read_to_string(b).unwrap(), "B");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }
}
