//! Inputs read once: the spec's text kept from its one read, the data files opened once
//! and, when a report records them, hashed as they are read.
//!
//! Why: an input may be a pipe or a named FIFO, which cannot be read twice (a second open
//! waits forever for a writer), and a file can change between two reads. So what the
//! report says was fitted (size and SHA-256) is the bytes the fit read, whatever the source.

use std::io::Read;
use std::path::{Path, PathBuf};

use lincal::data::{DataLayout, DataSource, Poses};
use lincal::error::Result;
use lincal::progress::Progress;
use lincal::report::html::InputFile;
use lincal::urdf;
use sha2::{Digest, Sha256};

/// The spec file's text, read once. Its fields are read, never changed (the `urdf:` record
/// is kept from the text).
pub struct SpecText {
    /// The path as given.
    pub path: PathBuf,
    /// Its whole text.
    pub text: String,
    /// Its `urdf:` record, once read ([`Self::urdf_record`]): a command reads it for the
    /// data's joint names, for the outputs' check and for `--write-urdf`, and each read
    /// parsed the whole YAML again.
    urdf: std::cell::OnceCell<Option<urdf::UrdfRecord>>,
}

impl SpecText {
    /// Reads the spec at `path` (bounded as every spec).
    ///
    /// # Errors
    /// The file cannot be read, is too large or is not UTF-8 (exit 2, naming it).
    pub fn read(path: &Path) -> Result<SpecText> {
        let text =
            lincal::error::read_input_file(path, "spec file", lincal::spec::load::MAX_SPEC_BYTES)?;
        Ok(SpecText {
            path: path.to_path_buf(),
            text,
            urdf: std::cell::OnceCell::new(),
        })
    }

    /// The spec's `urdf:` record, if it has one ([`urdf::UrdfRecord::from_spec_text`]), read
    /// once.
    ///
    /// # Errors
    /// The record is malformed, or the text is not YAML where it could hold one (it names
    /// `urdf` or has an escape): named, located; not cached, so each call reports it.
    pub fn urdf_record(&self) -> Result<Option<&urdf::UrdfRecord>> {
        if let Some(r) = self.urdf.get() {
            return Ok(r.as_ref());
        }
        let record = urdf::UrdfRecord::from_spec_text(&self.text, Some(&self.name()))?;
        Ok(self.urdf.get_or_init(|| record).as_ref())
    }

    /// The path for messages.
    pub fn name(&self) -> String {
        self.path.display().to_string()
    }

    /// The spec it holds.
    ///
    /// # Errors
    /// The spec's own errors, naming the file.
    pub fn spec(&self) -> Result<lincal::spec::Spec> {
        lincal::spec::from_yaml_str(&self.text, Some(&self.name()))
    }

    /// Its size and SHA-256, as the report records it.
    pub fn input_file(&self) -> InputFile {
        let mut t = Tally::default();
        t.add(self.text.as_bytes());
        t.input_file("spec", &self.path)
    }
}

/// The running size and SHA-256 of the bytes read from one input.
#[derive(Default)]
pub struct Tally {
    hasher: Sha256,
    bytes: u64,
}

impl Tally {
    fn add(&mut self, b: &[u8]) {
        self.hasher.update(b);
        self.bytes += b.len() as u64;
    }

    /// What the report records of the input at `path` in `role`.
    pub fn input_file(self, role: &str, path: &Path) -> InputFile {
        let digest = self.hasher.finalize();
        InputFile {
            role: role.to_string(),
            path: path.display().to_string(),
            bytes: self.bytes,
            sha256: digest.iter().map(|b| format!("{b:02x}")).collect(),
        }
    }
}

/// A reader that adds what it reads to a [`Tally`].
struct HashRead<'t, R> {
    inner: R,
    tally: &'t mut Tally,
}

impl<R: Read> Read for HashRead<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.tally.add(&buf[..n]);
        Ok(n)
    }
}

/// Reads the data files at `paths` once each, as [`Poses::from_csv_paths_progress`] does;
/// with `hash`, also the size and SHA-256 of the bytes each gave (in order).
///
/// # Errors
/// As [`Poses::from_csv_paths_progress`].
pub fn read_data(
    paths: &[PathBuf],
    layout: &DataLayout,
    progress: &dyn Progress,
    hash: bool,
) -> Result<(Poses, Vec<InputFile>)> {
    if !hash {
        let p: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
        return Ok((
            Poses::from_csv_paths_progress(&p, layout, progress)?,
            Vec::new(),
        ));
    }
    let mut tallies: Vec<Tally> = paths.iter().map(|_| Tally::default()).collect();
    let mut sources = Vec::with_capacity(paths.len());
    for (p, tally) in paths.iter().zip(tallies.iter_mut()) {
        let s = DataSource::open(p)?;
        sources.push(DataSource {
            reader: Box::new(HashRead {
                inner: s.reader,
                tally,
            }),
            name: s.name,
            size: s.size,
        });
    }
    let poses = Poses::from_csv_sources(sources, layout, progress)?;
    let files = tallies
        .into_iter()
        .zip(paths)
        .map(|(t, p)| t.input_file("data", p))
        .collect();
    Ok((poses, files))
}

#[cfg(test)]
mod tests {
    use super::Tally;
    use std::path::Path;

    #[test]
    fn tally_is_the_sha256_of_the_bytes() {
        let mut t = Tally::default();
        t.add(b"ab");
        t.add(b"c");
        let f = t.input_file("data", Path::new("x"));
        assert_eq!(f.bytes, 3);
        assert_eq!(
            f.sha256,
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
