//! Running one ONNX restoration model on an image (tiled) or a batch of images: the graph inputs its
//! contract declares, the session call, and the contract's reading of `restored`.

use crate::error::{BenchError, Result};
use crate::inputs::InputMaps;
use crate::tiling::{run_tiled, Tiling};
use unicac_image::Planar;
use unicac_onnx::contract::{ModelContract, ModelInput};
use unicac_onnx::runtime::{Session, Tensor};

fn invalid(message: String) -> BenchError {
    BenchError::InvalidInput(message)
}

/// Runs an ONNX restoration model on `lq` with the maps it declares, tiled as asked.
pub fn run_onnx(
    session: &mut Session,
    contract: &ModelContract,
    lq: &Planar,
    fov: Option<&Planar>,
    psf: Option<&Planar>,
    tiling: Tiling,
) -> Result<Planar> {
    let maps = InputMaps {
        fov,
        psf,
        ..InputMaps::default()
    };
    run_onnx_with(session, contract, lq, &maps, tiling)
}

/// [`run_onnx`] with every contract input available.
pub fn run_onnx_with(
    session: &mut Session,
    contract: &ModelContract,
    lq: &Planar,
    maps: &InputMaps,
    tiling: Tiling,
) -> Result<Planar> {
    let inputs = model_inputs(contract, lq, maps)?;
    let planes: Vec<&Planar> = inputs.iter().map(|(_, p)| *p).collect();
    let out = run_tiled(&planes, tiling, |_, tiles| {
        let named = inputs
            .iter()
            .zip(tiles)
            .map(|((name, _), t)| {
                (
                    *name,
                    Tensor {
                        shape: vec![1, t.channels, t.height, t.width],
                        data: t.data.clone(),
                    },
                )
            })
            .collect();
        let (w, h) = (tiles[0].width, tiles[0].height);
        let mut restored = run_restored(session, named, 1, w, h)?;
        Ok(restored.remove(0))
    })?;
    clamped_output(out)
}

/// Runs `images` (each with its maps; all of one size) through the model as one N x C x H x W batch,
/// untiled: the same outputs as one run per image (a convolutional network treats the batch's images
/// independently), for one call's overhead. Each image's result is checked on its own, so one
/// non-finite output fails only its image.
pub fn run_onnx_batch(
    session: &mut Session,
    contract: &ModelContract,
    images: &[(&Planar, InputMaps)],
) -> Result<Vec<Result<Planar>>> {
    let Some((first, _)) = images.first() else {
        return Ok(Vec::new());
    };
    let (w, h) = (first.width, first.height);
    if images.iter().any(|(lq, _)| (lq.width, lq.height) != (w, h)) {
        return Err(invalid("a batch holds images of one size".into()));
    }
    let per_image: Vec<Vec<(&'static str, &Planar)>> = images
        .iter()
        .map(|(lq, maps)| model_inputs(contract, lq, maps))
        .collect::<Result<_>>()?;
    let named = per_image[0]
        .iter()
        .enumerate()
        .map(|(index, (name, plane))| {
            let data = per_image
                .iter()
                .flat_map(|inputs| inputs[index].1.data.iter().copied())
                .collect();
            (
                *name,
                Tensor {
                    shape: vec![images.len(), plane.channels, h, w],
                    data,
                },
            )
        })
        .collect();
    let restored = run_restored(session, named, images.len(), w, h)?;
    Ok(restored.into_iter().map(clamped_output).collect())
}

/// The graph inputs `contract` declares, named, `lq` first.
fn model_inputs<'a>(
    contract: &ModelContract,
    lq: &'a Planar,
    maps: &InputMaps<'a>,
) -> Result<Vec<(&'static str, &'a Planar)>> {
    let mut inputs: Vec<(&'static str, &Planar)> = vec![("lq", lq)];
    for (input, map) in [
        (ModelInput::Fov, maps.fov),
        (ModelInput::Psf, maps.psf),
        (ModelInput::PsfCode, maps.psf_code),
        (ModelInput::Wiener, maps.wiener),
    ] {
        if contract.wants(input) {
            let map =
                map.ok_or_else(|| invalid(format!("model input `{}` is not available", input.name())))?;
            inputs.push((input.name(), map));
        }
    }
    Ok(inputs)
}

/// One session run; `restored` split into its `batch` images of `w` x `h`.
fn run_restored(
    session: &mut Session,
    named: Vec<(&str, Tensor)>,
    batch: usize,
    w: usize,
    h: usize,
) -> Result<Vec<Planar>> {
    let result = session.run(named, &["restored"])?.remove(0);
    if result.shape != [batch, 3, h, w] {
        return Err(invalid(format!(
            "`restored` has shape {:?}, expected [{batch}, 3, {h}, {w}]",
            result.shape
        )));
    }
    Ok(result
        .data
        .chunks_exact(3 * w * h)
        .map(|image| Planar {
            width: w,
            height: h,
            channels: 3,
            data: image.to_vec(),
        })
        .collect())
}

/// The contract's reading of `restored`: non-finite values are an error, others clamped to [0, 1].
fn clamped_output(mut out: Planar) -> Result<Planar> {
    if out.data.iter().any(|v| !v.is_finite()) {
        return Err(invalid("the model returned NaN or infinite values".into()));
    }
    out.data.iter_mut().for_each(|v| *v = v.clamp(0.0, 1.0));
    Ok(out)
}
