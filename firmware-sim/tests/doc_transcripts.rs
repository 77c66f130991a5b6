//! The `firmware-sim` transcripts on the documentation pages (the ```console blocks of README.md,
//! the crate READMEs and docs/) run against this build's binary, so a page cannot drift from
//! what the binary prints. host-trainer's transcripts run in host-trainer's own copy of this test.
//!
//! A test binary of its own: the pages' commands run from the repository root, and changing the
//! working directory must not reach the other tests.

#[test]
fn documentation_transcripts_match_the_binary() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the crate lives in the workspace");
    std::env::set_current_dir(root).expect("the repository root");
    // The pages write their examples' files under target/ (`scenario generate --out
    // target/...`), which a build with CARGO_TARGET_DIR elsewhere never creates.
    std::fs::create_dir_all("target").expect("the repository's target folder");
    trycmd::TestCases::new()
        .register_bin("firmware-sim", trycmd::cargo::cargo_bin!("firmware-sim"))
        .register_bin("host-trainer", trycmd::schema::Bin::Ignore)
        .case("README.md")
        .case("*/README.md")
        .case("docs/*.md")
        .case("docs/results/*.md");
}
