//! The committed C header matches what cbindgen generates from `src/ffi/`.

use std::path::Path;

#[test]
fn c_header_is_up_to_date() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src/ffi/mod.rs")) // and the modules it declares
        .generate()
        .expect("cbindgen generates the header");
    let mut generated = Vec::new();
    bindings.write(&mut generated);
    let path = dir.join("include/cliff_client.h");
    if std::env::var_os("CLIFF_BLESS").is_some() {
        std::fs::write(&path, &generated).expect("write the header");
        return;
    }
    let committed = std::fs::read(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "{} is stale: regenerate it with `CLIFF_BLESS=1 cargo test -p cliff-client --test c_header`",
        path.display()
    );
    let text = String::from_utf8(generated).unwrap();
    for f in [
        "cliff_client_connect",
        "cliff_predict",
        "cliff_request_add_agent",
        "cliff_client_reload_maps",
        "cliff_client_connect_zenoh",
        "CLIFF_CLIENT_ZENOH",
        "CLIFF_ERR_DEADLINE",
        "CLIFF_METHOD_IMPROVED 2",
        "CLIFF_FLAG_SCORES 1",
        "CLIFF_TIME_ALL_DAY 2",
        "cliff_prediction_best_sample",
        "const float *scores;",
    ] {
        assert!(text.contains(f), "{f} missing from the header");
    }
}

#[test]
fn c_header_compiles_as_c_and_as_cpp() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let include = dir.join("include");
    let example = dir.join("examples/c/cliff_predict.c");
    let runs: [(&str, &[&str]); 2] = [
        (
            "gcc",
            &[
                "-std=c99",
                "-Wall",
                "-Wextra",
                "-Werror",
                "-fsyntax-only",
                "-x",
                "c",
            ],
        ),
        (
            "g++",
            &[
                "-std=c++17",
                "-Wall",
                "-Wextra",
                "-Werror",
                "-fsyntax-only",
                "-x",
                "c++",
            ],
        ),
    ];
    for (compiler, flags) in runs {
        let out = std::process::Command::new(compiler)
            .args(flags)
            .arg("-I")
            .arg(&include)
            .arg(&example)
            .output()
            .unwrap_or_else(|e| panic!("run {compiler}: {e}"));
        assert!(
            out.status.success(),
            "{compiler} rejects the header or the example:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}
