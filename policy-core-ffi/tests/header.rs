//! The committed C header is what cbindgen makes of the source today: a change to the API that
//! is not in `include/policy_core.h` fails here. `UPDATE_HEADER=1` rewrites the file (as
//! `UPDATE_GOLDEN=1` rewrites policy-core's golden files). cbindgen ends its `extern "C"` block
//! with `//` comments, which C89 does not have: they become `/* */` here, so that the header
//! compiles as C89 (tests/c_host.rs compiles it so).

use std::path::Path;

#[test]
fn committed_header_is_the_generated_one() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(dir)
        .with_config(config)
        .generate()
        .expect("cbindgen generates the header")
        .write(&mut generated);
    let generated = c89_comments(&String::from_utf8(generated).expect("UTF-8"));
    let path = dir.join("include/policy_core.h");
    if std::env::var_os("UPDATE_HEADER").is_some() {
        std::fs::write(&path, &generated).expect("write the header");
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "{} differs from what cbindgen generates from the source; \
         run `UPDATE_HEADER=1 cargo test -p policy-core-ffi --test header` and commit it",
        path.display()
    );
}

/// The generated header with each line's trailing `// text` comment written `/* text */`.
fn c89_comments(header: &str) -> String {
    header
        .lines()
        .map(|line| match line.split_once("// ") {
            Some((code, comment)) if !code.trim_start().starts_with('*') => {
                format!("{code}/* {comment} */\n")
            }
            _ => format!("{line}\n"),
        })
        .collect()
}
