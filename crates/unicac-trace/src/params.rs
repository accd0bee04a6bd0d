//! Checks of the request parameters every face takes (field angles, wavelengths), written once here.
//! The error names the parameter in the library's words (`field_deg`, `wavelength_um`); each face
//! translates the name into its own (a CLI flag, a Python keyword).

/// A request parameter out of its range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct InvalidParameter {
    /// The parameter's library name.
    pub field: &'static str,
    /// The offending value and what was expected ("95: must lie strictly between -90 and 90").
    pub message: String,
}

impl InvalidParameter {
    pub fn new(field: &'static str, message: impl Into<String>) -> InvalidParameter {
        InvalidParameter {
            field,
            message: message.into(),
        }
    }
}

/// A field angle (deg) a ray can be aimed at: finite and strictly between -90 and 90.
pub fn check_field_deg(field_deg: f64) -> Result<f64, InvalidParameter> {
    if !(field_deg.is_finite() && field_deg.abs() < 90.0) {
        return Err(InvalidParameter::new(
            "field_deg",
            format!("{field_deg}: must lie strictly between -90 and 90"),
        ));
    }
    Ok(field_deg)
}

/// A wavelength (um) that is finite and positive.
pub fn check_wavelength_um(wavelength_um: f64) -> Result<f64, InvalidParameter> {
    if !(wavelength_um.is_finite() && wavelength_um > 0.0) {
        return Err(InvalidParameter::new(
            "wavelength_um",
            format!("{wavelength_um}: must be positive"),
        ));
    }
    Ok(wavelength_um)
}

/// Every field angle checked (`check_field_deg`); the error names the first bad one.
pub fn check_fields_deg(fields_deg: &[f64]) -> Result<(), InvalidParameter> {
    fields_deg.iter().try_for_each(|&f| check_field_deg(f).map(drop))
}

/// Every wavelength checked (`check_wavelength_um`); the error names the first bad one.
pub fn check_wavelengths_um(wavelengths_um: &[f64]) -> Result<(), InvalidParameter> {
    wavelengths_um
        .iter()
        .try_for_each(|&w| check_wavelength_um(w).map(drop))
}

/// A finite, strictly positive quantity (a pixel pitch, a length).
pub fn check_positive(field: &'static str, value: f64) -> Result<f64, InvalidParameter> {
    if !(value.is_finite() && value > 0.0) {
        return Err(InvalidParameter::new(field, format!("{value}: must be positive")));
    }
    Ok(value)
}

/// A count of at least `minimum`.
pub fn check_at_least(field: &'static str, value: usize, minimum: usize) -> Result<usize, InvalidParameter> {
    if value < minimum {
        return Err(InvalidParameter::new(
            field,
            format!("{value}: must be at least {minimum}"),
        ));
    }
    Ok(value)
}

/// An odd size (a kernel's side, so that it has a centre pixel).
pub fn check_odd(field: &'static str, value: usize) -> Result<usize, InvalidParameter> {
    if value % 2 != 1 {
        return Err(InvalidParameter::new(field, format!("{value}: must be odd")));
    }
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_fields_and_wavelengths_are_named() {
        assert_eq!(check_field_deg(-89.9), Ok(-89.9));
        for bad in [90.0, -95.0, f64::NAN, f64::INFINITY] {
            assert_eq!(check_field_deg(bad).unwrap_err().field, "field_deg");
        }
        let error = check_wavelengths_um(&[0.55, -1.0]).unwrap_err();
        assert_eq!(error.to_string(), "wavelength_um: -1: must be positive");
        assert!(check_wavelengths_um(&[0.55, 0.0]).is_err());
        assert!(check_fields_deg(&[0.0, 10.0]).is_ok());
    }

    #[test]
    fn sizes_and_pitches_are_named() {
        assert_eq!(check_positive("pixel_um", 2.0), Ok(2.0));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(check_positive("pixel_um", bad).unwrap_err().field, "pixel_um");
        }
        assert_eq!(
            check_at_least("oversample", 0, 1).unwrap_err().to_string(),
            "oversample: 0: must be at least 1"
        );
        assert_eq!(check_odd("max_kernel_px", 127), Ok(127));
        assert_eq!(
            check_odd("max_kernel_px", 128).unwrap_err().field,
            "max_kernel_px"
        );
    }
}
