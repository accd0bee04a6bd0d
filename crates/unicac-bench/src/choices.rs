//! What a bench run can be asked for, as types: the benchmarks, the metrics, the classical methods and
//! the split scored. Each name is the one the report and the faces use (`results.json`, the tables,
//! `--metrics psnr,ssim`), so parsing and printing are the same table read both ways.

use unicac_io::named_choice;

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
        /// The test pairs rendered through built units of the test lenses (`dataset build --as-built`).
        AsBuilt = "as_built",
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
