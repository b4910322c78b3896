//! The one cache of solved modal models, shared by scene builds and batch runs: models in
//! memory by content key (the most recently used `capacity` of them), and optionally on disk
//! as `.rmodal` files named by that key, so the next run loads instead of solving.
//!
//! Keys are BLAKE3 digests of what determines a model (the mesh's bytes or vertices, the
//! reference material, modes, resolution, scale): collisions across the 10⁶ files a dataset
//! may hold are out of the question.

use crate::error::Result;
use resound_core::ModalModel;
use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What identifies a model: a BLAKE3 digest.
pub type ModelKey = [u8; 32];

/// A key being built from what determines a model.
#[derive(Default)]
pub struct KeyBuilder(blake3::Hasher);

impl KeyBuilder {
    /// An empty key.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds bytes.
    pub fn bytes(&mut self, b: &[u8]) -> &mut Self {
        self.0.update(b);
        self
    }

    /// Adds numbers (little-endian).
    pub fn f64s(&mut self, xs: &[f64]) -> &mut Self {
        for x in xs {
            self.0.update(&x.to_le_bytes());
        }
        self
    }

    /// Adds a count.
    pub fn count(&mut self, n: usize) -> &mut Self {
        self.0.update(&(n as u64).to_le_bytes());
        self
    }

    /// The key.
    pub fn finish(&self) -> ModelKey {
        *self.0.finalize().as_bytes()
    }
}

/// Where solved models are cached by default: `$XDG_CACHE_HOME/resound/models`, else
/// `~/.cache/resound/models`; `None` with neither variable set.
pub fn default_dir() -> Option<PathBuf> {
    std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .map(|d| d.join("resound").join("models"))
}

/// Solved models in memory and, with a directory, on disk.
pub struct ModelCache {
    memory: HashMap<ModelKey, Arc<ModalModel>>,
    order: VecDeque<ModelKey>,
    capacity: usize,
    dir: Option<PathBuf>,
    solved: usize,
}

impl ModelCache {
    /// A cache keeping the `capacity` most recently used models in memory (at least one) and,
    /// with `dir`, every model on disk.
    pub fn new(dir: Option<PathBuf>, capacity: usize) -> Self {
        Self {
            memory: HashMap::new(),
            order: VecDeque::new(),
            capacity: capacity.max(1),
            dir,
            solved: 0,
        }
    }

    /// Models solved (not found in memory or on disk) so far.
    pub fn solved(&self) -> usize {
        self.solved
    }

    /// The file a model of `key` is kept in (with a directory).
    pub fn file(&self, key: &ModelKey) -> Option<PathBuf> {
        self.dir.as_ref().map(|d| {
            d.join(format!(
                "{}.rmodal",
                &blake3::Hash::from(*key).to_hex()[..32]
            ))
        })
    }

    /// The model of `key`: from memory, else from disk, else `solve`d (and stored). Returns
    /// it with its file (with a directory).
    ///
    /// # Errors
    /// `solve`'s error. A file that cannot be read is solved again; one that cannot be written
    /// only costs time later.
    pub fn get_or_solve(
        &mut self,
        key: ModelKey,
        solve: impl FnOnce() -> Result<ModalModel>,
    ) -> Result<(Arc<ModalModel>, Option<PathBuf>)> {
        let file = self.file(&key);
        if let Some(m) = self.memory.get(&key) {
            let m = Arc::clone(m);
            self.touch(key);
            return Ok((m, file));
        }
        let model = match file
            .as_ref()
            .and_then(|f| resound_io::model_file::load(f).ok())
        {
            Some(m) => m,
            None => {
                let m = solve()?;
                self.solved += 1;
                if let Some(f) = &file {
                    store(f, &m);
                }
                m
            }
        };
        let model = Arc::new(model);
        if self.order.len() >= self.capacity {
            if let Some(old) = self.order.pop_front() {
                self.memory.remove(&old);
            }
        }
        self.order.push_back(key);
        self.memory.insert(key, Arc::clone(&model));
        Ok((model, file))
    }

    fn touch(&mut self, key: ModelKey) {
        if let Some(k) = self.order.iter().position(|o| *o == key) {
            self.order.remove(k);
            self.order.push_back(key);
        }
    }
}

/// Writes `model` to the cache file `f` (its directory made); a failure only costs time later.
pub fn store(f: &Path, model: &ModalModel) {
    if let Some(d) = f.parent() {
        let _ = std::fs::create_dir_all(d);
    }
    let _ = resound_io::model_file::save(f, model);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(n: usize) -> ModalModel {
        let bar = resound_fem::primitive::bar([0.1, 0.02, 0.01]);
        resound_modal::ModalBuilder::surface(
            &bar,
            &resound_core::Material::preset("steel").unwrap(),
        )
        .modes(n)
        .solve()
        .unwrap()
        .model
    }

    #[test]
    fn a_model_is_solved_once_then_found_in_memory_or_on_disk() {
        let dir = tempfile::tempdir().unwrap();
        let key = KeyBuilder::new().bytes(b"bar").count(4).finish();
        let other = KeyBuilder::new().bytes(b"bar").count(5).finish();
        assert_ne!(key, other);
        let mut c = ModelCache::new(Some(dir.path().to_path_buf()), 1);
        let (a, f) = c.get_or_solve(key, || Ok(model(4))).unwrap();
        assert!(f.as_ref().is_some_and(|f| f.is_file()));
        // In memory: not solved again.
        let (b, _) = c.get_or_solve(key, || panic!("solved twice")).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        // Another key evicts it from memory (capacity 1); it comes back from disk, equal.
        c.get_or_solve(other, || Ok(model(5))).unwrap();
        let (d, _) = c
            .get_or_solve(key, || panic!("not read from disk"))
            .unwrap();
        assert!(!Arc::ptr_eq(&a, &d));
        assert_eq!(a.eigenvalues, d.eigenvalues);
        assert_eq!(c.solved(), 2);
        // Without a directory, eviction means solving again.
        let mut m = ModelCache::new(None, 1);
        m.get_or_solve(key, || Ok(model(4))).unwrap();
        m.get_or_solve(other, || Ok(model(5))).unwrap();
        m.get_or_solve(key, || Ok(model(4))).unwrap();
        assert_eq!(m.solved(), 3);
    }
}
