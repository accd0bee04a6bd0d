//! What a bench run can be asked for, as types: the benchmarks, the metrics, the classical methods and
//! the split scored. Each name is the one the report and the faces use (`results.json`, the tables,
//! `--metrics psnr,ssim`), so parsing and printing are the same table read both ways.

/// A name outside a choice's list.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{given}: unknown ({})", known.join(", "))]
pub struct UnknownName {
    pub given: String,
    pub known: Vec<&'static str>,
}

/// An enum of named unit variants: `ALL` in the order reports list them, `name()`, `Display`, `FromStr`
/// and serde as the name. Used across the crate (`#[macro_use]` in lib.rs; e.g. contract's `ModelInput`).
macro_rules! named_choice {
    ($(#[$doc:meta])* $ty:ident { $($(#[$vdoc:meta])* $variant:ident = $text:literal),+ $(,)? }) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
        #[derive(serde::Serialize, serde::Deserialize)]
        pub enum $ty {
            $($(#[$vdoc])* #[serde(rename = $text)] $variant),+
        }

        impl $ty {
            pub const ALL: &'static [$ty] = &[$($ty::$variant),+];

            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $text),+
                }
            }
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $ty {
            type Err = $crate::choices::UnknownName;

            fn from_str(text: &str) -> std::result::Result<$ty, $crate::choices::UnknownName> {
                $ty::ALL.iter().copied().find(|v| v.name() == text).ok_or_else(|| $crate::choices::UnknownName {
                    given: text.to_string(),
                    known: $ty::ALL.iter().map(|v| v.name()).collect(),
                })
            }
        }
    };
}

named_choice! {
    /// A benchmark: the main ODE levels or one of the two uniformity sub-benchmarks.
    Benchmark {
        Ode = "ode",
        /// Spatial uniformity (U_s) levels.
        Us = "us",
        /// Chromatic uniformity (U_c) levels.
        Uc = "uc",
    }
}

named_choice! {
    /// A metric of the report.
    Metric {
        Psnr = "psnr",
        Ssim = "ssim",
        Lpips = "lpips",
        Oiqe = "oiqe",
        Fid = "fid",
        ClipIqa = "clipiqa",
    }
}

named_choice! {
    /// A classical restoration method, beside the ONNX models.
    ClassicalMethod {
        /// The degraded image itself (always reported).
        Identity = "identity",
        /// Field-varying Wiener deconvolution with the dataset's PSF tables.
        Wiener = "wiener",
    }
}

named_choice! {
    /// The dataset split a run scores.
    Split {
        Test = "test",
        Val = "val",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_parses_back_to_its_choice() {
        for m in Metric::ALL {
            assert_eq!(m.name().parse::<Metric>(), Ok(*m));
        }
        for b in Benchmark::ALL {
            assert_eq!(b.to_string().parse::<Benchmark>(), Ok(*b));
        }
    }

    #[test]
    fn an_unknown_name_lists_the_known_ones() {
        let error = "mse".parse::<Metric>().unwrap_err();
        assert_eq!(
            error.to_string(),
            "mse: unknown (psnr, ssim, lpips, oiqe, fid, clipiqa)"
        );
    }

    #[test]
    fn choices_serialise_as_their_names() {
        let json = serde_json::to_string(&[Benchmark::Ode, Benchmark::Uc]).unwrap();
        assert_eq!(json, r#"["ode","uc"]"#);
    }
}
