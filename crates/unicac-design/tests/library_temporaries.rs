//! Issue 16: temporary files of killed runs (`.manifest.csv.tmp-*`) were never cleaned up.

#[test]
fn opening_a_library_removes_temporaries_of_killed_runs() {
    let dir = std::env::temp_dir().join(format!("unicac-design-temporaries-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("lenses")).unwrap();
    // Process ids above the kernel's maximum (4194304) are never alive: these writers are gone.
    let debris = [dir.join(".manifest.csv.tmp-4294967"), dir.join("lenses/.e3.json.tmp-4294968-0.json")];
    for path in &debris {
        std::fs::write(path, "half").unwrap();
    }
    unicac_design::library::Library::open(&dir).unwrap();
    if std::path::Path::new("/proc/self").exists() {
        for path in &debris {
            assert!(!path.exists(), "{}", path.display());
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
