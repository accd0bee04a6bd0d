use super::*;
use crate::quantise::from_code;
use std::path::PathBuf;

/// An image whose every sample is an exact `bits`-bit code value, with codes spread over the full range.
fn coded_image(width: usize, height: usize, channels: usize, max_code: u32) -> Planar {
    Planar::from_fn(width, height, channels, |c, x, y| {
        let code = ((c * 7919 + y * 613 + x * 97) as u32).wrapping_mul(2_654_435_761) % (max_code + 1);
        from_code(code, max_code)
    })
}

fn entries(folder: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(folder)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect()
}

#[test]
fn png_8_and_16_bit_round_trips_are_exact_for_every_channel_count() {
    let folder = tempfile::tempdir().unwrap();
    for (depth, bits, max) in [(SampleDepth::Eight, 8, 255), (SampleDepth::Sixteen, 16, 65535)] {
        for channels in 1..=4 {
            let image = coded_image(37, 23, channels, max);
            let path = folder.path().join(format!("round_{bits}_{channels}.png"));
            write_png(&path, &image, depth).unwrap();
            let loaded = read_image(&path).unwrap();
            assert_eq!(loaded.format, FileFormat::Png);
            assert_eq!(loaded.bit_depth, bits);
            assert_eq!(loaded.encoding, Encoding::Srgb);
            assert_eq!(loaded.channel_names.len(), channels);
            assert_eq!(loaded.image, image, "{bits}-bit, {channels} channels");
        }
    }
}

#[test]
fn tiff_16_and_8_bit_round_trips_are_exact() {
    let folder = tempfile::tempdir().unwrap();
    for (depth, bits, max) in [(SampleDepth::Sixteen, 16, 65535), (SampleDepth::Eight, 8, 255)] {
        for channels in [1, 3, 4] {
            let image = coded_image(41, 19, channels, max);
            let path = folder.path().join(format!("round_{bits}_{channels}.tif"));
            write_tiff(&path, &image, depth).unwrap();
            let loaded = read_image(&path).unwrap();
            assert_eq!((loaded.format, loaded.bit_depth), (FileFormat::Tiff, bits));
            assert_eq!(loaded.image, image, "{bits}-bit, {channels} channels");
        }
    }
}

#[test]
fn exr_round_trip_is_bit_exact_f32_including_extreme_values() {
    let folder = tempfile::tempdir().unwrap();
    let specials = [
        0.0,
        -0.0,
        1e-40,
        -3.5,
        65_504.0,
        1e30,
        f32::NAN,
        f32::INFINITY,
        0.1,
        1.0 / 3.0,
    ];
    let image = Planar::from_fn(13, 11, 3, |c, x, y| {
        let i = (c * 11 + y) * 13 + x;
        if i % 17 == 0 {
            specials[i % specials.len()]
        } else {
            (i as f32 * 0.618_034).sin() * 10f32.powi((i % 9) as i32 - 4)
        }
    });
    let path = folder.path().join("linear.exr");
    write_exr(&path, &image).unwrap();
    let loaded = read_image(&path).unwrap();
    assert_eq!(
        (loaded.format, loaded.bit_depth, loaded.encoding),
        (FileFormat::OpenExr, 32, Encoding::Linear)
    );
    assert_eq!(loaded.channel_names, ["R", "G", "B"]);
    let bits = |p: &Planar| p.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!((loaded.image.width, loaded.image.height), (13, 11));
    assert_eq!(bits(&loaded.image), bits(&image));
}

#[test]
fn exr_named_channels_round_trip_in_documented_order() {
    let folder = tempfile::tempdir().unwrap();
    let stack = Planar::from_fn(9, 9, 4, |c, x, y| (c * 100 + y * 9 + x) as f32 * 1e-3);
    let path = folder.path().join("psf_stack.exr");
    write_exr_channels(&path, &stack, &["psf_0450nm", "psf_0550nm", "psf_0650nm", "Y"]).unwrap();
    let loaded = read_image(&path).unwrap();
    // "Y" is a well-known name and comes first; the others follow in name order.
    assert_eq!(
        loaded.channel_names,
        ["Y", "psf_0450nm", "psf_0550nm", "psf_0650nm"]
    );
    assert_eq!(loaded.image.plane(0), stack.plane(3));
    assert_eq!(loaded.image.plane(1), stack.plane(0));
    assert_eq!(loaded.image.plane(3), stack.plane(2));
}

#[test]
fn unreadable_empty_and_garbage_files_give_typed_errors_naming_the_path() {
    let folder = tempfile::tempdir().unwrap();
    let missing = folder.path().join("missing.png");
    let empty = folder.path().join("empty.png");
    let garbage = folder.path().join("garbage.tif");
    let truncated = folder.path().join("truncated.png");
    std::fs::write(&empty, b"").unwrap();
    std::fs::write(&garbage, b"this is not an image at all").unwrap();
    std::fs::write(&truncated, b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR\0\0").unwrap();
    type IsKind = fn(&ImageError) -> bool;
    let cases: [(&PathBuf, IsKind); 4] = [
        (&missing, |e| matches!(e, ImageError::Io { .. })),
        (&empty, |e| matches!(e, ImageError::EmptyFile { .. })),
        (&garbage, |e| matches!(e, ImageError::UnknownFormat { .. })),
        (&truncated, |e| {
            matches!(e, ImageError::Decode { format: "PNG", .. })
        }),
    ];
    for (path, is_expected_kind) in cases {
        let error = read_image(path).unwrap_err();
        assert!(is_expected_kind(&error), "{path:?}: {error:?}");
        assert!(error.to_string().contains(&path.display().to_string()), "{error}");
    }
    let mut corrupt_exr = vec![0x76, 0x2f, 0x31, 0x01];
    corrupt_exr.extend_from_slice(&[0xff; 64]);
    let exr_path = folder.path().join("corrupt.exr");
    std::fs::write(&exr_path, corrupt_exr).unwrap();
    assert!(matches!(
        read_image(&exr_path),
        Err(ImageError::Decode {
            format: "OpenEXR",
            ..
        })
    ));
    // Reading never creates files.
    assert_eq!(entries(folder.path()).len(), 4);
}

#[test]
fn failed_writes_name_the_path_and_leave_no_file_behind() {
    let folder = tempfile::tempdir().unwrap();
    let target = folder.path().join("out.png");
    let with_nan = Planar::from_fn(4, 4, 3, |c, x, _| if c == 1 && x == 2 { f32::NAN } else { 0.5 });
    let broken_layout = Planar {
        width: 4,
        height: 4,
        channels: 3,
        data: vec![0.5; 10],
    };
    let five_channels = Planar::new(4, 4, 5);
    let empty = Planar::new(0, 4, 3);
    let errors = [
        write_png(&target, &with_nan, SampleDepth::Eight).unwrap_err(),
        write_tiff(&target, &broken_layout, SampleDepth::Sixteen).unwrap_err(),
        write_png(&target, &five_channels, SampleDepth::Sixteen).unwrap_err(),
        write_png(&target, &empty, SampleDepth::Eight).unwrap_err(),
        write_exr(&target, &five_channels).unwrap_err(),
        write_exr_channels(&target, &Planar::new(4, 4, 2), &["R", "R"]).unwrap_err(),
        write_exr_channels(&target, &Planar::new(4, 4, 2), &["R"]).unwrap_err(),
    ];
    for error in &errors {
        assert!(matches!(error, ImageError::Encode { .. }), "{error:?}");
        assert!(
            error.to_string().contains(&target.display().to_string()),
            "{error}"
        );
    }
    assert!(
        entries(folder.path()).is_empty(),
        "left behind: {:?}",
        entries(folder.path())
    );

    let no_folder = folder.path().join("no/such/folder/out.exr");
    let error = write_exr(&no_folder, &Planar::new(2, 2, 1)).unwrap_err();
    assert!(
        matches!(error, ImageError::Io { .. }) && error.to_string().contains("no/such/folder"),
        "{error}"
    );
}

#[test]
fn a_failed_write_keeps_the_previous_file_intact() {
    let folder = tempfile::tempdir().unwrap();
    let target = folder.path().join("keep.tif");
    let good = coded_image(8, 8, 3, 65535);
    write_tiff(&target, &good, SampleDepth::Sixteen).unwrap();
    let bad = Planar::from_fn(8, 8, 3, |_, _, _| f32::INFINITY);
    assert!(write_tiff(&target, &bad, SampleDepth::Sixteen).is_err());
    assert_eq!(read_image(&target).unwrap().image, good);
    assert_eq!(entries(folder.path()), [target]);
}

#[test]
fn to_linear_decodes_colour_planes_but_not_alpha() {
    let folder = tempfile::tempdir().unwrap();
    let path = folder.path().join("rgba.png");
    let image = Planar::from_fn(2, 1, 4, |_, _, _| from_code(128, 255));
    write_png(&path, &image, SampleDepth::Eight).unwrap();
    let linear = read_image(&path).unwrap().to_linear();
    let expected = crate::color::srgb_decode(from_code(128, 255));
    assert_eq!(linear.plane(0), [expected; 2]);
    assert_eq!(linear.plane(3), [from_code(128, 255); 2]);
}

#[test]
fn values_outside_unit_range_are_clipped_by_integer_writers() {
    let folder = tempfile::tempdir().unwrap();
    let path = folder.path().join("clip.png");
    let image = Planar::from_fn(2, 1, 1, |_, x, _| if x == 0 { -0.5 } else { 1.5 });
    write_png(&path, &image, SampleDepth::Sixteen).unwrap();
    assert_eq!(read_image(&path).unwrap().image.data, [0.0, 1.0]);
}

#[test]
fn into_linear_rgb_is_rgb_planes_of_to_linear_for_every_layout() {
    let folder = tempfile::tempdir().unwrap();
    for channels in 1..=4 {
        let path = folder.path().join(format!("c{channels}.png"));
        write_png(&path, &coded_image(5, 3, channels, 65535), SampleDepth::Sixteen).unwrap();
        let loaded = read_image(&path).unwrap();
        let expected = loaded.rgb_planes(&loaded.to_linear()).unwrap();
        assert_eq!(loaded.into_linear_rgb().unwrap(), expected, "{channels} channels");
    }
}

#[test]
fn declared_size_reads_png_and_tiff_headers_only() {
    let folder = tempfile::tempdir().unwrap();
    let png = folder.path().join("a.png");
    let tiff = folder.path().join("a.tif");
    let exr = folder.path().join("a.exr");
    let image = coded_image(7, 4, 3, 255);
    write_png(&png, &image, SampleDepth::Eight).unwrap();
    write_tiff(&tiff, &image, SampleDepth::Sixteen).unwrap();
    write_exr(&exr, &image).unwrap();
    assert_eq!(declared_size(&png), Some((7, 4)));
    assert_eq!(declared_size(&tiff), Some((7, 4)));
    assert_eq!(declared_size(&exr), None, "OpenEXR: left to the decoder");
    assert_eq!(declared_size(folder.path().join("missing.png")), None);
    let truncated = folder.path().join("t.png");
    std::fs::write(&truncated, &std::fs::read(&png).unwrap()[..12]).unwrap();
    assert_eq!(declared_size(&truncated), None);
}

#[test]
fn large_pngs_are_streamed_and_read_back_exactly() {
    let folder = tempfile::tempdir().unwrap();
    // Both above png_stream's 8 MiB threshold: 16-bit RGB (9.6 MB) and 8-bit grey (9 MB).
    for (image, depth, max) in [
        (coded_image(1600, 1000, 3, 65535), SampleDepth::Sixteen, 65535),
        (coded_image(3000, 3000, 1, 255), SampleDepth::Eight, 255),
    ] {
        assert!(super::png_stream::worth_streaming(
            image.data.len() * (max as usize + 1).ilog2() as usize / 8
        ));
        let path = folder.path().join("large.png");
        write_png(&path, &image, depth).unwrap();
        assert_eq!(read_image(&path).unwrap().image, image);
    }
    assert_eq!(entries(folder.path()), [folder.path().join("large.png")]);
}
