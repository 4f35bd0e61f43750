//! The cache of spec facts ([`SpecFacts`]: the identifiability analysis and `K`), so that
//! fitting the same spec again skips its exact analysis.
//!
//! One small JSON file per spec, named by the SHA-256 of lincal's version, the term bound and
//! the parsed spec (every field, so any change to the spec is a different file), in
//! `$LINCAL_CACHE_DIR`, else `$XDG_CACHE_HOME/lincal`, else `$HOME/.cache/lincal`;
//! `LINCAL_CACHE=off` turns it off. The cache can only save time: a file that is missing,
//! unreadable, too large, not JSON or not of the spec's shape is ignored (the analysis runs),
//! and a write goes to a temporary file renamed into place, any failure ignored.

use std::io::Read;
use std::path::PathBuf;

use lincal::spec::Spec;
use lincal::symbolic::SpecFacts;
use sha2::{Digest, Sha256};

/// The format of the files (part of the key).
const FORMAT: &str = "lincal spec facts v1";

/// The largest cache file read (facts of a spec with thousands of parameters are far less).
const MAX_BYTES: u64 = 16 << 20;

/// A spec's place in the cache and what was found there.
pub struct FactsCache {
    /// The file, when the cache is on.
    path: Option<PathBuf>,
    /// The facts read from it, if any fit to use.
    found: Option<SpecFacts>,
}

impl FactsCache {
    /// Looks `spec` (with the expansion bound `max_terms`) up in the cache.
    pub fn open(spec: &Spec, max_terms: usize) -> Self {
        let path = cache_dir().map(|d| d.join(format!("{}.json", key(spec, max_terms))));
        let found = path.as_ref().and_then(|p| read(p));
        FactsCache { path, found }
    }

    /// The facts found, for [`lincal::symbolic::SymbolicModel::for_fitting_with`].
    pub fn found(&self) -> Option<SpecFacts> {
        self.found.clone()
    }

    /// Keeps `facts` when they say more than what was found (best effort, silent).
    pub fn store(&self, facts: &SpecFacts) {
        let Some(path) = &self.path else { return };
        if self.found.as_ref() == Some(facts) {
            return;
        }
        let _ = write(path, facts);
    }
}

/// The cache directory, or `None` when the cache is off or no place is known.
fn cache_dir() -> Option<PathBuf> {
    if std::env::var_os("LINCAL_CACHE").is_some_and(|v| v == "off") {
        return None;
    }
    let non_empty = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    non_empty("LINCAL_CACHE_DIR")
        .or_else(|| non_empty("XDG_CACHE_HOME").map(|d| d.join("lincal")))
        .or_else(|| non_empty("HOME").map(|d| d.join(".cache").join("lincal")))
}

/// The file name's key: SHA-256 (hex) of the format, lincal's version and build (the
/// executable's size and modification time: a rebuilt engine never reads an older one's
/// facts), the bound and the spec's every field.
fn key(spec: &Spec, max_terms: usize) -> String {
    let mut h = Sha256::new();
    h.update(FORMAT.as_bytes());
    h.update([0]);
    h.update(env!("CARGO_PKG_VERSION").as_bytes());
    h.update([0]);
    h.update(build_identity().as_bytes());
    h.update([0]);
    h.update(max_terms.to_le_bytes());
    h.update([0]);
    h.update(format!("{spec:?}").as_bytes());
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// The running executable's size and modification time (empty when unknown).
fn build_identity() -> String {
    std::env::current_exe()
        .and_then(std::fs::metadata)
        .map(|m| {
            let t = m
                .modified()
                .ok()
                .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                .map_or(0, |d| d.as_nanos());
            format!("{} {t}", m.len())
        })
        .unwrap_or_default()
}

/// The facts in `path`, when it holds readable JSON of the right form.
fn read(path: &std::path::Path) -> Option<SpecFacts> {
    let f = std::fs::File::open(path).ok()?;
    let mut bytes = Vec::new();
    f.take(MAX_BYTES + 1).read_to_end(&mut bytes).ok()?;
    if bytes.len() as u64 > MAX_BYTES {
        return None;
    }
    serde_json::from_slice(&bytes).ok()
}

/// Writes `facts` to `path` through a temporary file beside it and a rename.
fn write(path: &std::path::Path, facts: &SpecFacts) -> std::io::Result<()> {
    let dir = path.parent().ok_or(std::io::ErrorKind::InvalidInput)?;
    std::fs::create_dir_all(dir)?;
    let json = serde_json::to_vec(facts).map_err(std::io::Error::other)?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        path.file_name().and_then(|n| n.to_str()).unwrap_or("facts"),
        std::process::id()
    ));
    std::fs::write(&tmp, json)?;
    std::fs::rename(&tmp, path).inspect_err(|_| {
        let _ = std::fs::remove_file(&tmp);
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The key follows every field of the spec and the bound.
    #[test]
    fn the_key_changes_with_the_spec_and_the_bound() {
        let yaml = "name: a\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  - {type: revolute, a: a2, home: th2}\nparams: {a1: {nominal: 0.3}, th1: {nominal: 0}, a2: {nominal: 0.4}, th2: {nominal: 0}, b1: {nominal: -1.7}, b2: {nominal: -0.6}}\nconstraint: {line: {b: [b1, b2]}}\n";
        let a = lincal::spec::from_yaml_str(yaml, None).expect("spec");
        let b = lincal::spec::from_yaml_str(&yaml.replace("0.4", "0.41"), None).expect("spec");
        assert_eq!(key(&a, 10), key(&a, 10));
        assert_ne!(key(&a, 10), key(&b, 10));
        assert_ne!(key(&a, 10), key(&a, 11));
    }
}
