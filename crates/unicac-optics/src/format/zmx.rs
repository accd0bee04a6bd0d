//! Zemax OpticStudio `.zmx` (sequential) import and export.
//!
//! Supported: UTF-16 (with BOM, or detected by NUL bytes) and UTF-8 files; STANDARD and EVENASPH surfaces
//! (CURV, DISZ, DIAM, CONI, PARM n = coefficient of r^(2n), STOP, GLAS with catalogue names and model
//! glasses `___BLANK`, COMM); COORDBRK surfaces (PARM 1-6: decentre x, y, tilt about x, y, z, order),
//! folded into the decentre and tilt of the surfaces they move (see `breaks`); ENPD, FNUM, FLOA
//! apertures; field angles and paraxial image heights (FTYP 0 / 2, YFLN, FWGN/FWGT); WAVM or WAVL/WWGT
//! wavelengths and PWAV; GCAT.
//! Anything that changes the optics and is not modelled (other surface types, a surface's own
//! tilt/decenter keywords, x fields, mirrors, non-mm units, non-sequential mode) is an error naming the
//! keyword; other unknown keywords are returned as warnings, never silently dropped.

use super::breaks::{self, Break};
use super::LoadedSpec;
use crate::error::{OpticsError, Result};
use crate::spec::{
    ApertureSpec, FieldSpec, LensSpec, MaterialSpec, SurfaceSpec, SurfaceType, WavelengthSpec, FORMAT_VERSION,
};
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::Path;

/// Keywords read elsewhere or known to carry no optical meaning for this model.
const IGNORED: &[&str] = &[
    "VERS", "PFIL", "LANG", "ENVD", "GFAC", "RAIM", "PUSH", "SDMA", "ROPD", "PICB", "POLS", "GLRS", "NSCD",
    "COFN", "HIDE", "SLAB", "MAZH", "POPS", "FLAP", "COAT", "DMFS", "BLNK", "TOL", "MNUM", "MOFF", "TOLE",
    "XDAT", "YDAT", "OBNS", "OBDC", "MIRR", "PPAR", "FIMP", "CONF", "VCXN", "VCYN", "VANN", "VDSZ", "XFLD",
    "YFLD", "TCMM", "PZUP", "BLNK", "EFFL", "FWGN", "FWGT", "THIC", "NOTE", "MEMA", "TTST", "OPDX", "SCOL",
    "XFIE", "YFIE", "EFFM", "LANG", "ZVAN", "ZVCX", "ZVCY", "ZVDX", "ZVDY", "WWGN", "PRAM", "CTOL",
];

/// Parses a `.zmx` file.
pub fn parse(bytes: &[u8], path: &Path) -> Result<LoadedSpec> {
    let text = decode(bytes);
    let mut reader = Reader::new(path);
    // Every writer ends each record with a line break, so a last line without one is a file cut inside
    // a record: `DIAM 21.5` cut to `DIAM 2` would still parse, as a different lens.
    if let Some((index, last)) = text.lines().enumerate().last() {
        if !last.trim().is_empty() && !text.ends_with(['\n', '\r']) {
            return Err(reader.error(
                index + 1,
                format!(
                    "`{}` ends the file without a line break: the file ends inside a record (is it truncated?)",
                    last.trim()
                ),
            ));
        }
    }
    for (number, line) in text.lines().enumerate() {
        reader.line(number + 1, line)?;
    }
    reader.finish()
}

/// Decodes UTF-16 (LE or BE, with BOM, or LE detected by NUL bytes) or UTF-8 (lossy, BOM skipped).
fn decode(bytes: &[u8]) -> String {
    let utf16 = |le: bool, body: &[u8]| {
        let units: Vec<u16> = body
            .chunks_exact(2)
            .map(|p| {
                if le {
                    u16::from_le_bytes([p[0], p[1]])
                } else {
                    u16::from_be_bytes([p[0], p[1]])
                }
            })
            .collect();
        String::from_utf16_lossy(&units)
    };
    match bytes {
        [0xFF, 0xFE, body @ ..] => utf16(true, body),
        [0xFE, 0xFF, body @ ..] => utf16(false, body),
        [0xEF, 0xBB, 0xBF, body @ ..] => String::from_utf8_lossy(body).into_owned(),
        _ if bytes.len() >= 2 && bytes[1] == 0 => utf16(true, bytes),
        _ => String::from_utf8_lossy(bytes).into_owned(),
    }
}

/// What the reader saw of one SURF block, for the structure checks of `finish`.
#[derive(Debug, Clone, Copy)]
struct SurfaceBlock {
    line: usize,
    declared_index: Option<usize>,
    has_curvature: bool,
    has_thickness: bool,
}

struct Reader<'a> {
    path: &'a Path,
    name: String,
    provenance: String,
    aperture: Option<ApertureSpec>,
    field_type: u32,
    field_count: Option<usize>,
    y_fields: Vec<f64>,
    field_weights: Vec<f64>,
    wavelengths: Vec<(usize, WavelengthSpec)>,
    old_wavelengths: Vec<f64>,
    old_weights: Vec<f64>,
    primary: Option<usize>,
    catalogs: Vec<String>,
    /// Surfaces in file order, starting with the object surface (SURF 0).
    surfaces: Vec<SurfaceSpec>,
    parms: Vec<Vec<(usize, f64)>>,
    /// Per surface: whether it is a coordinate break (TYPE COORDBRK).
    coordinate_breaks: Vec<bool>,
    /// Per surface: the line of its SURF keyword and whether CURV and DISZ were given (structure checks).
    blocks: Vec<SurfaceBlock>,
    object_distance: Option<f64>,
    unsupported: BTreeSet<String>,
    warnings: BTreeSet<String>,
}

impl<'a> Reader<'a> {
    fn new(path: &'a Path) -> Self {
        Reader {
            path,
            name: String::new(),
            provenance: String::new(),
            aperture: None,
            field_type: 0,
            field_count: None,
            y_fields: Vec::new(),
            field_weights: Vec::new(),
            wavelengths: Vec::new(),
            old_wavelengths: Vec::new(),
            old_weights: Vec::new(),
            primary: None,
            catalogs: Vec::new(),
            surfaces: Vec::new(),
            parms: Vec::new(),
            coordinate_breaks: Vec::new(),
            blocks: Vec::new(),
            object_distance: None,
            unsupported: BTreeSet::new(),
            warnings: BTreeSet::new(),
        }
    }

    fn error(&self, line: usize, message: impl Into<String>) -> OpticsError {
        OpticsError::Parse {
            path: self.path.to_path_buf(),
            location: line.to_string(),
            message: message.into(),
        }
    }

    fn number(&self, line: usize, token: Option<&str>, what: &str) -> Result<f64> {
        let token = token.ok_or_else(|| self.error(line, format!("{what}: missing value")))?;
        if token.eq_ignore_ascii_case("INFINITY") {
            return Ok(f64::INFINITY);
        }
        token
            .parse::<f64>()
            .map_err(|_| self.error(line, format!("{what}: '{token}' is not a number")))
    }

    fn numbers(&self, line: usize, tokens: &[&str], what: &str) -> Result<Vec<f64>> {
        tokens.iter().map(|t| self.number(line, Some(t), what)).collect()
    }

    fn current(&mut self, line: usize, keyword: &str) -> Result<&mut SurfaceSpec> {
        let path = self.path.to_path_buf();
        self.surfaces.last_mut().ok_or_else(|| OpticsError::Parse {
            path,
            location: line.to_string(),
            message: format!("{keyword} before the first SURF"),
        })
    }

    /// The block of the current surface (`current` has been called, so there is one).
    fn block(&mut self) -> &mut SurfaceBlock {
        self.blocks.last_mut().expect("a SURF block")
    }

    /// A file cut short or edited by hand must not load as a smaller lens: every SURF block is
    /// numbered in order and complete (Zemax writes CURV and DISZ for every surface), one surface is
    /// the stop, and PWAV names a listed wavelength.
    fn check_structure(&self) -> Result<()> {
        for (position, block) in self.blocks.iter().enumerate() {
            if block.declared_index != Some(position) {
                return Err(self.error(
                    block.line,
                    format!("surface blocks must be numbered SURF 0, 1, 2, ...; expected SURF {position}"),
                ));
            }
            if !(block.has_curvature && block.has_thickness) {
                return Err(self.error(
                    block.line,
                    format!(
                        "SURF {position} has no {}: the surface is incomplete (is the file truncated?)",
                        if block.has_curvature { "DISZ" } else { "CURV" }
                    ),
                ));
            }
        }
        self.check_image_surface()?;
        let stops = self.surfaces.iter().filter(|s| s.stop).count();
        if stops != 1 {
            return Err(self.error(
                0,
                format!("{stops} surfaces are marked STOP; a lens file marks exactly one (is the file truncated?)"),
            ));
        }
        if let Some(primary) = self.primary {
            let listed: Vec<usize> = if self.wavelengths.is_empty() {
                self.old_wavelengths
                    .iter()
                    .enumerate()
                    .filter(|(_, w)| **w > 0.0)
                    .map(|(i, _)| i + 1)
                    .collect()
            } else {
                self.wavelengths.iter().map(|(i, _)| *i).collect()
            };
            if !listed.contains(&primary) {
                return Err(self.error(
                    0,
                    format!("PWAV {primary}: no such wavelength (listed: {listed:?})"),
                ));
            }
        }
        Ok(())
    }

    /// The last SURF block is the image surface. Zemax writes it with DISZ 0 and no glass, and any
    /// interior surface has a thickness to the next one (every bundled lens's does) or a glass after
    /// it, so a file cut at a surface boundary ends on a block that cannot be the image surface.
    fn check_image_surface(&self) -> Result<()> {
        let (Some(block), Some(image)) = (self.blocks.last(), self.surfaces.last()) else {
            return Ok(());
        };
        let index = self.blocks.len() - 1;
        if image.thickness_mm != 0.0 {
            return Err(self.error(
                block.line,
                format!(
                    "SURF {index}, the last surface, is the image surface but has DISZ {} (the image \
                     surface has DISZ 0): the surfaces after it are missing (is the file truncated?)",
                    image.thickness_mm
                ),
            ));
        }
        if let Some(material) = image.material.as_ref().filter(|m| !m.is_air()) {
            let name = match material {
                MaterialSpec::Named(name) => name.clone(),
                MaterialSpec::Model { nd, vd } => format!("___BLANK (nd {nd}, vd {vd})"),
            };
            return Err(self.error(
                block.line,
                format!(
                    "SURF {index}, the last surface, is the image surface but has GLAS {name}: nothing \
                     follows the image surface, so the surfaces after it are missing (is the file truncated?)"
                ),
            ));
        }
        if image.stop {
            return Err(self.error(
                block.line,
                format!(
                    "SURF {index}, the last surface, is the image surface but is marked STOP: the \
                     surfaces after it are missing (is the file truncated?)"
                ),
            ));
        }
        Ok(())
    }

    fn line(&mut self, n: usize, line: &str) -> Result<()> {
        let trimmed = line.trim();
        let (keyword, rest) = trimmed.split_once(char::is_whitespace).unwrap_or((trimmed, ""));
        let rest = rest.trim();
        let tokens: Vec<&str> = rest.split_whitespace().collect();
        match keyword {
            "" => {}
            "MODE" if !rest.eq_ignore_ascii_case("SEQ") => {
                self.unsupported
                    .insert(format!("MODE {rest} (only sequential mode)"));
            }
            "MODE" => {}
            "NAME" => self.name = rest.to_string(),
            "NOTE" => {
                if let Some(json) = rest.strip_prefix("0 unicac:provenance ") {
                    self.provenance = serde_json::from_str(json).map_err(|e| self.error(n, e.to_string()))?;
                }
            }
            "UNIT" if tokens.first().is_some_and(|u| !u.eq_ignore_ascii_case("MM")) => {
                self.unsupported
                    .insert(format!("UNIT {} (only MM lens units)", tokens[0]));
            }
            "UNIT" => {}
            "ENPD" => {
                self.aperture = Some(ApertureSpec::EntrancePupilDiameterMm(self.number(
                    n,
                    tokens.first().copied(),
                    "ENPD",
                )?))
            }
            "FNUM" => {
                self.aperture = Some(ApertureSpec::FNumber(self.number(
                    n,
                    tokens.first().copied(),
                    "FNUM",
                )?))
            }
            "FLOA" => self.aperture = Some(ApertureSpec::FloatByStopSize),
            "OBNA" | "OBSC" if keyword == "OBNA" => {
                self.unsupported.insert("OBNA (object-space NA aperture)".into());
            }
            "FTYP" => {
                let values = self.numbers(n, &tokens, "FTYP")?;
                self.field_type = values.first().copied().unwrap_or(0.0) as u32;
                self.field_count = values.get(2).map(|v| *v as usize);
                if values.get(1).is_some_and(|t| *t != 0.0) {
                    self.unsupported.insert("FTYP telecentric object space".into());
                }
            }
            "XFLN" => {
                if self.numbers(n, &tokens, "XFLN")?.iter().any(|x| *x != 0.0) {
                    self.unsupported.insert("XFLN (fields off the y axis)".into());
                }
            }
            "YFLN" => self.y_fields = self.numbers(n, &tokens, "YFLN")?,
            "FWGN" | "FWGT" => self.field_weights = self.numbers(n, &tokens, keyword)?,
            "VDXN" | "VDYN" | "VCXN" | "VCYN" | "VANN" => {
                if self.numbers(n, &tokens, keyword)?.iter().any(|v| *v != 0.0) {
                    self.warnings
                        .insert(format!("{keyword} (vignetting factors ignored)"));
                }
            }
            "WAVM" => {
                let values = self.numbers(n, &tokens, "WAVM")?;
                if let [index, wavelength, weight, ..] = values[..] {
                    self.wavelengths.push((
                        index as usize,
                        WavelengthSpec {
                            wavelength_um: wavelength,
                            weight,
                        },
                    ));
                }
            }
            "WAVL" => self.old_wavelengths = self.numbers(n, &tokens, "WAVL")?,
            "WWGT" => self.old_weights = self.numbers(n, &tokens, "WWGT")?,
            "PWAV" => {
                let primary = self.number(n, tokens.first().copied(), "PWAV")?;
                if !((1.0..=1e6).contains(&primary) && primary.fract() == 0.0) {
                    return Err(self.error(
                        n,
                        format!("PWAV {primary}: expected a wavelength number 1, 2, ..."),
                    ));
                }
                self.primary = Some(primary as usize);
            }
            "GCAT" => self.catalogs = tokens.iter().map(|t| t.to_ascii_uppercase()).collect(),
            "SURF" => {
                self.surfaces.push(SurfaceSpec::default());
                self.parms.push(Vec::new());
                self.coordinate_breaks.push(false);
                self.blocks.push(SurfaceBlock {
                    line: n,
                    declared_index: tokens.first().and_then(|t| t.parse().ok()),
                    has_curvature: false,
                    has_thickness: false,
                });
            }
            "TYPE" => {
                let surface_type = match tokens.first().copied() {
                    Some("STANDARD") => SurfaceType::Standard,
                    Some("EVENASPH") => SurfaceType::EvenAsphere,
                    Some("COORDBRK") => {
                        self.current(n, keyword)?;
                        *self.coordinate_breaks.last_mut().expect("a surface") = true;
                        SurfaceType::Standard
                    }
                    other => {
                        self.unsupported.insert(format!("TYPE {}", other.unwrap_or("")));
                        SurfaceType::Standard
                    }
                };
                self.current(n, keyword)?.surface_type = surface_type;
            }
            "CURV" => {
                let c = self.number(n, tokens.first().copied(), "CURV")?;
                self.current(n, keyword)?.curvature_per_mm = Some(c);
                self.block().has_curvature = true;
            }
            "DISZ" => {
                let d = self.number(n, tokens.first().copied(), "DISZ")?;
                self.current(n, keyword)?;
                self.block().has_thickness = true;
                if self.surfaces.len() == 1 {
                    self.object_distance = d.is_finite().then_some(d);
                } else {
                    self.current(n, keyword)?.thickness_mm = d;
                }
            }
            "CONI" => {
                let k = self.number(n, tokens.first().copied(), "CONI")?;
                self.current(n, keyword)?.conic = k;
            }
            "PARM" => {
                let values = self.numbers(n, &tokens, "PARM")?;
                if let [index, value, ..] = values[..] {
                    self.current(n, keyword)?;
                    self.parms
                        .last_mut()
                        .expect("a surface")
                        .push((index as usize, value));
                }
            }
            "DIAM" => {
                let sd = self.number(n, tokens.first().copied(), "DIAM")?;
                if !(sd >= 0.0 && sd.is_finite()) {
                    return Err(self.error(n, format!("DIAM {sd}: a semi-diameter must be finite and >= 0")));
                }
                self.current(n, keyword)?.semi_diameter_mm = (sd > 0.0).then_some(sd);
            }
            "STOP" => self.current(n, keyword)?.stop = true,
            "COMM" => {
                let label = rest.to_string();
                self.current(n, keyword)?.label = label;
            }
            "GLAS" => {
                let material = self.material(n, &tokens)?;
                self.current(n, keyword)?.material = material;
            }
            "DECX" | "DECY" | "TILT" | "SQAP" | "ELAP" | "OBSC" | "CLAP" | "FLAP_" => {
                let values = self.numbers(n, &tokens, keyword).unwrap_or_default();
                if keyword == "CLAP" {
                    self.unsupported
                        .insert("CLAP (circular aperture; use DIAM)".into());
                } else if values.iter().any(|v| *v != 0.0) {
                    self.unsupported
                        .insert(format!("{keyword} (decentres, tilts and special apertures)"));
                }
            }
            k if IGNORED.contains(&k) => {}
            other => {
                self.warnings.insert(format!("{other} (keyword ignored)"));
            }
        }
        Ok(())
    }

    fn material(&mut self, n: usize, tokens: &[&str]) -> Result<Option<MaterialSpec>> {
        match tokens.first().copied() {
            None => Ok(None),
            Some("MIRROR") => {
                self.unsupported
                    .insert("GLAS MIRROR (reflective surfaces)".into());
                Ok(None)
            }
            Some("___BLANK") => {
                let nd = self.number(n, tokens.get(3).copied(), "GLAS ___BLANK nd")?;
                let vd = self.number(n, tokens.get(4).copied(), "GLAS ___BLANK vd")?;
                Ok(Some(MaterialSpec::Model { nd, vd }))
            }
            Some(name) => Ok(Some(MaterialSpec::Named(name.to_string()))),
        }
    }

    fn finish(mut self) -> Result<LoadedSpec> {
        if self.surfaces.len() < 3 {
            return Err(self.error(
                0,
                "need an object surface, at least one surface and the image surface",
            ));
        }
        if !self.unsupported.is_empty() {
            let features: Vec<String> = self.unsupported.into_iter().collect();
            return Err(OpticsError::UnsupportedZemax {
                path: self.path.to_path_buf(),
                features: features.join("; "),
            });
        }
        self.check_structure()?;
        for ((surface, parms), &is_break) in self
            .surfaces
            .iter_mut()
            .zip(&self.parms)
            .zip(&self.coordinate_breaks)
        {
            if surface.surface_type == SurfaceType::EvenAsphere && !is_break {
                let count = parms.iter().map(|(i, _)| *i).max().unwrap_or(0).min(10);
                surface.aspheric_coefficients = vec![0.0; count];
                for &(i, value) in parms {
                    if (1..=count).contains(&i) {
                        surface.aspheric_coefficients[i - 1] = value;
                    }
                }
            }
        }
        let object = self.surfaces.remove(0);
        if object.stop {
            return Err(self.error(0, "the object surface cannot be the stop"));
        }
        if self.coordinate_breaks[0] {
            return Err(self.error(
                self.blocks[0].line,
                "the object surface cannot be a coordinate break",
            ));
        }
        if self.coordinate_breaks.iter().any(|b| *b) {
            let steps = self
                .surfaces
                .drain(..)
                .zip(self.coordinate_breaks.iter().skip(1))
                .zip(self.parms.iter().skip(1))
                .zip(self.blocks.iter().skip(1))
                .map(|(((surface, &is_break), parms), block)| {
                    if is_break {
                        breaks::Step::Break(
                            Break::from_parms(parms),
                            surface.thickness_mm,
                            block.line,
                            surface.stop,
                        )
                    } else {
                        breaks::Step::Surface(surface)
                    }
                })
                .collect::<Vec<_>>();
            self.surfaces = breaks::resolve(steps).map_err(|(line, message)| self.error(line, message))?;
        }
        let fields = self.fields()?;
        let field_count = fields.values().len();
        let field_weights =
            (self.field_weights.len() >= field_count).then(|| self.field_weights[..field_count].to_vec());
        let (wavelengths, primary) = self.wavelengths();
        Ok(LoadedSpec {
            spec: LensSpec {
                format_version: FORMAT_VERSION,
                name: self.name,
                provenance: self.provenance,
                object_distance_mm: self.object_distance,
                aperture: self.aperture.ok_or_else(|| OpticsError::Parse {
                    path: self.path.to_path_buf(),
                    location: "0".into(),
                    message: "no aperture (ENPD, FNUM or FLOA)".into(),
                })?,
                fields,
                field_weights,
                wavelengths,
                primary_wavelength_index: primary,
                glass_catalogs: self.catalogs,
                surfaces: self.surfaces,
                sensor: None,
            },
            warnings: self.warnings.into_iter().collect(),
        })
    }

    fn fields(&self) -> Result<FieldSpec> {
        let count = self.field_count.unwrap_or_else(|| {
            // Old files do not state the count: fields end at the first zero after the first entry.
            1 + self.y_fields.iter().skip(1).take_while(|v| **v != 0.0).count()
        });
        let values: Vec<f64> = self.y_fields.iter().copied().take(count.max(1)).collect();
        let values = if values.is_empty() { vec![0.0] } else { values };
        match self.field_type {
            0 => Ok(FieldSpec::AnglesDeg(values)),
            2 => Ok(FieldSpec::ImageHeightsMm(values)),
            other => Err(OpticsError::UnsupportedZemax {
                path: self.path.to_path_buf(),
                features: format!("FTYP {other} (only field angles and paraxial image heights)"),
            }),
        }
    }

    fn wavelengths(&self) -> (Vec<WavelengthSpec>, Option<usize>) {
        let mut list: Vec<(usize, WavelengthSpec)> = self.wavelengths.clone();
        if list.is_empty() {
            list = self
                .old_wavelengths
                .iter()
                .enumerate()
                .filter(|(_, w)| **w > 0.0)
                .map(|(i, w)| {
                    (
                        i + 1,
                        WavelengthSpec {
                            wavelength_um: *w,
                            weight: self.old_weights.get(i).copied().unwrap_or(1.0),
                        },
                    )
                })
                .collect();
        }
        list.sort_by_key(|(i, _)| *i);
        let primary = self.primary.and_then(|p| list.iter().position(|(i, _)| *i == p));
        (list.into_iter().map(|(_, w)| w).collect(), primary)
    }
}

/// Writes a spec as a UTF-8 `.zmx` file that OpticStudio, optiland and ray-optics import.
/// Floats are written in their shortest exact form, so JSON -> .zmx -> JSON is lossless.
pub fn to_string(spec: &LensSpec) -> String {
    let mut out = String::new();
    let mut line = |text: String| {
        out.push_str(&text);
        out.push('\n');
    };
    line("VERS 190513 80 123457 L123457".into());
    line("MODE SEQ".into());
    line(format!("NAME {}", spec.name));
    if !spec.provenance.is_empty() {
        line(format!(
            "NOTE 0 unicac:provenance {}",
            serde_json::to_string(&spec.provenance).expect("string")
        ));
    }
    line("UNIT MM X W X CM MR CPMM".into());
    match spec.aperture {
        ApertureSpec::EntrancePupilDiameterMm(d) => line(format!("ENPD {d:?}")),
        ApertureSpec::FNumber(f) => line(format!("FNUM {f:?} 0")),
        ApertureSpec::FloatByStopSize => line("FLOA".into()),
    }
    let (field_type, values) = match &spec.fields {
        FieldSpec::AnglesDeg(v) => (0, v),
        FieldSpec::ImageHeightsMm(v) => (2, v),
    };
    line(format!(
        "FTYP {field_type} 0 {} {} 0 0 0",
        values.len(),
        spec.wavelengths.len()
    ));
    line(format!("XFLN {}", join(&vec![0.0; values.len()])));
    line(format!("YFLN {}", join(values)));
    if let Some(weights) = &spec.field_weights {
        line(format!("FWGN {}", join(weights)));
    }
    for (i, w) in spec.wavelengths.iter().enumerate() {
        line(format!("WAVM {} {:?} {:?}", i + 1, w.wavelength_um, w.weight));
    }
    if let Some(p) = spec.primary_wavelength_index {
        line(format!("PWAV {}", p + 1));
    }
    if !spec.glass_catalogs.is_empty() {
        line(format!("GCAT {}", spec.glass_catalogs.join(" ")));
    }
    line("SURF 0".into());
    line("  TYPE STANDARD".into());
    line("  CURV 0.0".into());
    match spec.object_distance_mm {
        Some(d) => line(format!("  DISZ {d:?}")),
        None => line("  DISZ INFINITY".into()),
    }
    // A spec without a stop has its stop at surface 1 (as `Lens::from_spec` reads it); the file says so,
    // since the reader requires one STOP.
    let implicit_stop = !spec.surfaces.iter().any(|s| s.stop);
    let mut number = 0;
    for (i, s) in spec.surfaces.iter().enumerate() {
        // A decentred or tilted surface sits between coordinate breaks that place it and then undo
        // the move, so the following surfaces stay on the nominal axis (`breaks::around`).
        let (before, after) = breaks::around(&s.placement());
        for b in &before {
            number += 1;
            line(format!("SURF {number}"));
            write_break(b, 0.0, &mut line);
        }
        number += 1;
        line(format!("SURF {number}"));
        if i == 0 && implicit_stop {
            line("  STOP".into());
        }
        let mut placed = s.clone();
        if !after.is_empty() {
            placed.thickness_mm = 0.0;
        }
        write_surface(&placed, i + 1 == spec.surfaces.len(), &mut line);
        for (k, b) in after.iter().enumerate() {
            number += 1;
            line(format!("SURF {number}"));
            let thickness = if k + 1 == after.len() { s.thickness_mm } else { 0.0 };
            write_break(b, thickness, &mut line);
        }
    }
    out
}

fn write_break(b: &Break, thickness_mm: f64, line: &mut impl FnMut(String)) {
    line("  TYPE COORDBRK".into());
    line("  CURV 0.0 0 0 0 0 \"\"".into());
    for (i, value) in b.parms().iter().enumerate() {
        line(format!("  PARM {} {value:?}", i + 1));
    }
    line(format!("  DISZ {thickness_mm:?}"));
}

/// The image surface (`image`) is written as Zemax writes it, DISZ 0 and no glass, whatever the spec
/// holds there (nothing follows it, so neither changes the lens; the reader requires both).
fn write_surface(s: &SurfaceSpec, image: bool, line: &mut impl FnMut(String)) {
    if !s.label.is_empty() {
        line(format!("  COMM {}", s.label));
    }
    if s.stop {
        line("  STOP".into());
    }
    match s.surface_type {
        SurfaceType::Standard => line("  TYPE STANDARD".into()),
        SurfaceType::EvenAsphere => line("  TYPE EVENASPH".into()),
    }
    line(format!("  CURV {:?} 0 0 0 0 \"\"", s.curvature()));
    for (i, a) in s.aspheric_coefficients.iter().enumerate() {
        line(format!("  PARM {} {a:?}", i + 1));
    }
    line(format!("  DISZ {:?}", if image { 0.0 } else { s.thickness_mm }));
    match &s.material {
        _ if image => {}
        None => {}
        Some(MaterialSpec::Named(name)) => {
            let bare = name.split_once(':').map_or(name.as_str(), |(_, g)| g);
            line(format!("  GLAS {bare} 0 0 0 0 0 0 0 0 0 0"));
        }
        Some(MaterialSpec::Model { nd, vd }) => {
            line(format!("  GLAS ___BLANK 1 0 {nd:?} {vd:?} 0 0 0 0 0 0"))
        }
    }
    if let Some(sd) = s.semi_diameter_mm {
        line(format!("  DIAM {sd:?} 1 0 0 1 \"\""));
    }
    if s.conic != 0.0 {
        line(format!("  CONI {:?}", s.conic));
    }
}

fn join(values: &[f64]) -> String {
    let mut text = String::new();
    for (i, v) in values.iter().enumerate() {
        if i > 0 {
            text.push(' ');
        }
        let _ = write!(text, "{v:?}");
    }
    text
}
