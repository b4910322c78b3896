//! The modal models and acoustic transfers of one scene build: solved once per shape,
//! material and resolution, kept in the content-hashed model cache.

use super::*;

/// The modal model of a scene body: from the model cache (identical bodies are solved once
/// per build even without a cache directory), solved when it is in neither memory nor the
/// directory. Returns it with its cache file.
pub(super) fn modal_model(
    mesh: &SurfaceMesh,
    material: &Material,
    b: &BodyFile,
    models: &mut ModelCache,
) -> Result<(std::sync::Arc<ModalModel>, Option<PathBuf>)> {
    let mut key = KeyBuilder::new();
    for v in &mesh.vertices {
        key.f64s(v);
    }
    for t in &mesh.triangles {
        for c in t {
            key.bytes(&c.to_le_bytes());
        }
    }
    key.f64s(&[
        material.youngs_modulus,
        material.poisson_ratio,
        material.density,
    ])
    .count(b.modes)
    .count(b.resolution);
    models.get_or_solve(key.finish(), || {
        let params = ModalParams {
            n_modes: Some(b.modes),
            max_freq_hz: None,
            resolution: b.resolution,
            target_voxels: if b.resolution == 0 { 1500 } else { 0 },
            sturm_check: false,
            ..Default::default()
        };
        Ok(ModalBuilder::surface(mesh, material)
            .params(params)
            .solve()?
            .model)
    })
}

/// Acoustic transfers fitted or loaded during one scene build, by modal model.
pub(super) type Transfers =
    std::collections::HashMap<usize, std::sync::Arc<resound_core::AcousticTransfer>>;

/// The acoustic transfer of a scene body's `model`: the model's own, else fitted (default
/// settings) and stored with the model in the cache, so the next build loads it.
pub(super) fn body_transfer(
    model: &std::sync::Arc<ModalModel>,
    cache_file: Option<&Path>,
    transfers: &mut Transfers,
    progress: ProgressFn<'_>,
) -> Result<std::sync::Arc<resound_core::AcousticTransfer>> {
    let key = std::sync::Arc::as_ptr(model) as usize;
    if let Some(t) = transfers.get(&key) {
        return Ok(std::sync::Arc::clone(t));
    }
    let t = match &model.transfer {
        Some(t) => std::sync::Arc::new(t.clone()),
        None => {
            progress(Progress::begin(Stage::Transfer));
            let mut m = (**model).clone();
            crate::radiation::add_transfer(
                &mut m,
                &resound_modal::radiation::TransferParams::default(),
            )?;
            if let Some(f) = cache_file {
                crate::model_cache::store(f, &m);
            }
            std::sync::Arc::new(
                m.transfer
                    .take()
                    .ok_or_else(|| invalid("the acoustic transfer fit stored nothing"))?,
            )
        }
    };
    transfers.insert(key, std::sync::Arc::clone(&t));
    Ok(t)
}
