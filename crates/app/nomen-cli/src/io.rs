//! File handling shared by the subcommands: `-` means stdin/stdout, paths are named in errors.

use anyhow::{Context, Result, bail};
use nomen_core::bounded::{Limits, MIB_BYTES, read_to_end_bounded, read_to_string_bounded};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Reads a whole text file (`-` is standard input) as a stream within `limits`: a line or a
/// file past them is an error naming the file, the line and the limit, whatever size the file
/// system reports (0 for `/dev/zero` and pipes).
pub fn read_text(path: &Path, limits: Limits) -> Result<String> {
    let name = source_name(path);
    if is_std_stream(path) {
        return Ok(read_to_string_bounded(
            std::io::stdin().lock(),
            &name,
            limits,
        )?);
    }
    let file = File::open(path).with_context(|| format!("cannot read {name}"))?;
    Ok(read_to_string_bounded(file, &name, limits)?)
}

/// Reads a whole binary file (a model's weights) as a stream within `limits`.
pub fn read_bytes(path: &Path, limits: Limits) -> Result<Vec<u8>> {
    let name = source_name(path);
    let file = File::open(path).with_context(|| format!("cannot read {name}"))?;
    Ok(read_to_end_bounded(file, &name, limits)?)
}

/// The largest settings file read (a scenario, an engine configuration, a registry, an RSSI
/// model, a CNN model's metadata), bytes: 4 MiB. The library's scenarios are 1–24 kB; parsing
/// TOML takes about a hundred times a file's size in memory.
pub const MAX_SETTINGS_BYTES: u64 = 4 * MIB_BYTES;

/// The limits of a settings file: [`MAX_SETTINGS_BYTES`] in all, any line length within it
/// (JSON may be written on one line).
pub const SETTINGS_LIMITS: Limits =
    Limits::text("a settings file", MAX_SETTINGS_BYTES, MAX_SETTINGS_BYTES);

/// [`read_text`] for a settings file, within [`SETTINGS_LIMITS`].
pub fn read_settings(path: &Path) -> Result<String> {
    read_text(path, SETTINGS_LIMITS)
}

/// Standard output, locked: `let mut stdout = crate::io::stdout(); writeln!(stdout, ...)?;`.
///
/// Every command prints through this instead of `println!`, which panics when the write fails: a
/// reader that stops early (`nomen eval --json | head`) closes the pipe, and the write error must
/// come back to `main` (which exits quietly on a broken pipe). Line-buffered like `println!`, so
/// the bytes and their interleaving with stderr are the same.
pub fn stdout() -> std::io::StdoutLock<'static> {
    std::io::stdout().lock()
}

/// Whether `path` is `-`: standard input where a command reads, standard output where it writes.
pub fn is_std_stream(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// Creates `path` (and its parent folders) for buffered writing; `-` is standard output.
pub fn create_write(path: &Path) -> Result<Box<dyn Write>> {
    if is_std_stream(path) {
        return Ok(Box::new(BufWriter::new(std::io::stdout().lock())));
    }
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create folder {}", parent.display()))?;
    }
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    Ok(Box::new(BufWriter::with_capacity(1 << 16, file)))
}

/// Creates `path` for buffered writing as [`create_write`] does, but through `PATH.partial`,
/// renamed to `path` by [`OutFile::commit`] once everything is written: a command killed or
/// stopped by an error before then leaves `PATH.partial`, never a cut file under the final
/// name, and the previous `path` stays whole. A `path` that exists and is not a regular file
/// (`/dev/null`, a named pipe) is written directly, as is `-`.
pub fn create_write_renamed(path: &Path) -> Result<OutFile> {
    if is_std_stream(path) || path.metadata().is_ok_and(|m| !m.is_file()) {
        return Ok(OutFile::Direct(create_write(path)?));
    }
    let partial = partial_path(path);
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("cannot create folder {}", parent.display()))?;
    }
    let file =
        File::create(&partial).with_context(|| format!("cannot create {}", partial.display()))?;
    Ok(OutFile::Partial {
        inner: BufWriter::with_capacity(1 << 16, file),
        partial,
        path: path.to_path_buf(),
    })
}

/// Writes `bytes` to `path` through `PATH.partial` ([`create_write_renamed`]): the file gets
/// its name only once whole.
pub fn write_renamed(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut out = create_write_renamed(path)?;
    out.write_all(bytes)
        .with_context(|| format!("cannot write {}", sink_name(path)))?;
    out.commit()
}

/// Refuses `path` as an input when it is an output still being written, or left by a command
/// that stopped before its end: a name ending in `.partial` ([`create_write_renamed`]), or a
/// missing file whose `PATH.partial` exists.
pub fn check_whole(path: &Path) -> Result<()> {
    if is_std_stream(path) {
        return Ok(());
    }
    let partial = partial_path(path);
    if !path.exists() && partial.exists() {
        bail!(
            "{} does not exist, but {} does: the command writing it stopped before its end (or \
             is still running)",
            path.display(),
            partial.display()
        );
    }
    if path
        .file_name()
        .is_some_and(|n| n.to_string_lossy().ends_with(".partial"))
    {
        let whole = path.with_extension("");
        bail!(
            "{} is a partial output: the command writing it stopped before its end (or is \
             still running), and it holds only what came before; the whole result is named {}",
            path.display(),
            whole.display()
        );
    }
    Ok(())
}

/// `PATH.partial`: where [`create_write_renamed`] writes `path` until it is whole.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_owned();
    name.push(".partial");
    path.with_file_name(name)
}

/// An output written directly, or under `PATH.partial` until [`OutFile::commit`] gives it its
/// name ([`create_write_renamed`]).
pub enum OutFile {
    /// A standard stream or a file that is not a regular one.
    Direct(Box<dyn Write>),
    /// A regular file written under a temporary name.
    Partial {
        /// The open `partial` file.
        inner: BufWriter<File>,
        /// `PATH.partial`.
        partial: PathBuf,
        /// The final name.
        path: PathBuf,
    },
}

impl OutFile {
    /// Flushes everything and gives the file its final name; dropped without this, the
    /// output keeps its partial name.
    pub fn commit(self) -> Result<()> {
        match self {
            OutFile::Direct(mut out) => Ok(out.flush()?),
            OutFile::Partial {
                mut inner,
                partial,
                path,
            } => {
                inner
                    .flush()
                    .with_context(|| format!("cannot write {}", partial.display()))?;
                drop(inner);
                std::fs::rename(&partial, &path).with_context(|| {
                    format!(
                        "cannot give {} its name {}: what was written is in it",
                        partial.display(),
                        path.display()
                    )
                })
            }
        }
    }
}

impl Write for OutFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            OutFile::Direct(out) => out.write(buf),
            OutFile::Partial { inner, .. } => inner.write(buf),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            OutFile::Direct(out) => out.flush(),
            OutFile::Partial { inner, .. } => inner.flush(),
        }
    }
}

/// Refuses to run when an output would overwrite an input or another output: `nomen run
/// rec.jsonl --out rec.jsonl` would truncate the recording before reading it. Paths are compared
/// after following symbolic links; `-` (a standard stream) is never compared, nor are `None`s.
pub fn check_distinct(inputs: &[Option<&Path>], outputs: &[Option<&Path>]) -> Result<()> {
    let named = |paths: &[Option<&Path>]| -> Vec<(PathBuf, PathBuf)> {
        paths
            .iter()
            .flatten()
            .filter(|p| !is_std_stream(p))
            .map(|p| (p.to_path_buf(), resolved(p)))
            .collect()
    };
    let (inputs, outputs) = (named(inputs), named(outputs));
    for (k, (out, out_id)) in outputs.iter().enumerate() {
        if let Some((input, _)) = inputs.iter().find(|(_, id)| id == out_id) {
            bail!(
                "the output {} is the input {}: writing it would destroy what is to be read \
                 (choose another output path)",
                out.display(),
                input.display()
            );
        }
        if let Some((other, _)) = outputs.iter().skip(k + 1).find(|(_, id)| id == out_id) {
            bail!(
                "two outputs are the same file, {} and {}: the second would overwrite the first",
                out.display(),
                other.display()
            );
        }
    }
    Ok(())
}

/// `path` with symbolic links followed, for [`check_distinct`]: the canonical path of an
/// existing file, or of its folder joined with its name for a file yet to be written.
fn resolved(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    let parent = parent.map_or_else(|| Path::new(".").canonicalize(), Path::canonicalize);
    match (parent, path.file_name()) {
        (Ok(dir), Some(name)) => dir.join(name),
        _ => path.to_path_buf(),
    }
}

/// A display name for an output path in messages (`-` is `<stdout>`).
pub fn sink_name(path: &Path) -> String {
    if is_std_stream(path) {
        "<stdout>".to_owned()
    } else {
        path.display().to_string()
    }
}

/// A display name for a path in error messages (`-` is `<stdin>`).
pub fn source_name(path: &Path) -> String {
    if is_std_stream(path) {
        "<stdin>".to_owned()
    } else {
        path.display().to_string()
    }
}

/// The file `relative` names inside `root` (a scenario's clip in the data folder, a path in a
/// settings file relative to that file's folder), refused unless it stays inside: `relative`
/// must be a relative path without `..` (an absolute path or `../` is refused before anything
/// is opened), and the path must resolve, symbolic links followed, to a place inside `root` (for
/// a file yet to be written, its nearest existing folder). `what` names the path in errors
/// (`clip file`, `registry of serve.toml`).
pub fn path_inside(root: &Path, relative: &str, what: &str) -> Result<PathBuf> {
    use std::path::Component;
    let rel = Path::new(relative);
    let is_plain = !relative.is_empty()
        && rel
            .components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir));
    if !is_plain {
        bail!(
            "{what} '{relative}' is not inside {}: it must be a relative path without '..'",
            root.display()
        );
    }
    let path = root.join(rel);
    let resolved = path.ancestors().find_map(|p| p.canonicalize().ok());
    if let (Some(inside), Ok(root_resolved)) = (resolved, root.canonicalize())
        && !inside.starts_with(&root_resolved)
    {
        bail!(
            "{what} '{relative}' leads out of {} (a symbolic link to {}): refused",
            root.display(),
            inside.display()
        );
    }
    Ok(path)
}

/// Finds the shared data folder: the flag, `$NOMEN_DATA`, `../shared/data`, or the one beside the
/// source checkout this binary was built from.
pub fn find_data(flag: Option<&Path>) -> Result<PathBuf> {
    let mut candidates: Vec<PathBuf> = Vec::new();
    if let Some(f) = flag {
        candidates.push(f.to_owned());
    } else {
        if let Some(env) = std::env::var_os("NOMEN_DATA") {
            candidates.push(env.into());
        }
        candidates.push("../shared/data".into());
        candidates.push(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../../shared/data"));
    }
    for c in &candidates {
        if c.join("mocap/cmu/18_01.bvh").is_file() {
            return Ok(c.clone());
        }
    }
    let tried: Vec<String> = candidates.iter().map(|c| c.display().to_string()).collect();
    bail!(
        "the shared data folder was not found (tried {}); pass --data DIR or set NOMEN_DATA",
        tried.join(", ")
    )
}

/// Every message of a recording file, and its header's registry; stops at the first bad line,
/// naming the file.
pub fn read_messages(
    path: &Path,
) -> Result<(Vec<nomen_core::Message>, Option<nomen_core::Registry>)> {
    let recording =
        nomen_recording::read_file(path).with_context(|| format!("reading {}", path.display()))?;
    Ok((recording.messages, recording.header.registry))
}

/// A scene folder as `nomen simulate` writes it: the messages of `recording.jsonl`, the
/// registry its header carries (an error without one) and the messages of `truth.jsonl`.
pub fn read_scene(
    dir: &Path,
) -> Result<(
    Vec<nomen_core::Message>,
    nomen_core::Registry,
    Vec<nomen_core::Message>,
)> {
    let recording_path = dir.join("recording.jsonl");
    let (recording, registry) = read_messages(&recording_path)?;
    let Some(registry) = registry else {
        bail!(
            "{}: the header carries no registry",
            recording_path.display()
        );
    };
    let (truth, _) = read_messages(&dir.join("truth.jsonl"))?;
    Ok((recording, registry, truth))
}

/// A progress bar of `len` steps with a message, drawn on stderr when it is a terminal and
/// hidden otherwise.
pub fn step_progress_bar(len: u64) -> indicatif::ProgressBar {
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg:>24} [{bar:40}] {pos}/{len}").map_or_else(
            |_| indicatif::ProgressStyle::default_bar(),
            |s| s.progress_chars("=> "),
        ),
    );
    bar
}
