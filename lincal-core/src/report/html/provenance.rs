//! Where a report came from: the input files with their sizes and SHA-256 hashes, the
//! command line and version ([`Provenance`]), and the worst poses' CSV lines read back.
//!
//! Takes file paths (and wanted line numbers); gives [`InputFile`]s and line texts.

use std::fmt::Write as _;
use std::io::Read;
use std::path::Path;

use sha2::{Digest, Sha256};

/// One input file of a run, identified for reproducibility.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InputFile {
    /// What it is (`spec`, `data`).
    pub role: String,
    /// The path as given on the command line.
    pub path: String,
    /// Its size in bytes.
    pub bytes: u64,
    /// SHA-256 of its content, lower-case hex.
    pub sha256: String,
}

impl InputFile {
    /// Reads `path` (streamed) and hashes it.
    ///
    /// # Errors
    /// The file cannot be read.
    pub fn hash(role: &str, path: &Path) -> std::io::Result<InputFile> {
        let mut file = std::fs::File::open(path)?;
        let mut hasher = Sha256::new();
        let mut buf = vec![0u8; 1 << 16];
        let mut bytes = 0u64;
        loop {
            let n = file.read(&mut buf)?;
            if n == 0 {
                break;
            }
            bytes += n as u64;
            hasher.update(&buf[..n]);
        }
        let digest = hasher.finalize();
        let mut sha256 = String::with_capacity(64);
        for b in digest.iter() {
            let _ = write!(sha256, "{b:02x}");
        }
        Ok(InputFile {
            role: role.to_string(),
            path: path.display().to_string(),
            bytes,
            sha256,
        })
    }
}

/// How the report was made: what a reader needs to run it again.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Provenance {
    /// The command line, as typed (shell-quoted where needed).
    pub command: String,
    /// The lincal version that made the report.
    pub version: String,
    /// The input files with their hashes.
    pub files: Vec<InputFile>,
}

/// The text of the given 1-based lines of a file (each line at most once, in file order),
/// read in one streamed pass that stops after the last wanted line (lines end at LF, CRLF or
/// a bare CR, as the data reader's do).
///
/// # Errors
/// The file cannot be read.
pub fn csv_lines(path: &Path, wanted: &[usize]) -> std::io::Result<Vec<(usize, String)>> {
    let mut want: Vec<usize> = wanted.iter().copied().filter(|&l| l > 0).collect();
    want.sort_unstable();
    want.dedup();
    let Some(&last) = want.last() else {
        return Ok(Vec::new());
    };
    let mut reader = std::io::BufReader::new(std::fs::File::open(path)?);
    let mut out = Vec::with_capacity(want.len());
    let mut buf = Vec::new();
    let mut line = 0;
    while line < last {
        // Lines end as the data reader ends them (LF, CRLF or a bare CR), so the numbers agree.
        let read = crate::data::lines::read_line(&mut reader, &mut buf, None, line + 1)
            .map_err(|e| std::io::Error::other(e.to_string()))?;
        if read == 0 {
            break;
        }
        line += 1;
        if want.binary_search(&line).is_ok() {
            let text = String::from_utf8_lossy(&buf);
            out.push((line, text.trim_end_matches(['\r', '\n']).to_string()));
        }
    }
    Ok(out)
}
