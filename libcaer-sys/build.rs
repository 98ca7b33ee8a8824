//! Links libcaer through pkg-config, or, with the `mock` feature, compiles the C mock
//! in `mock/` that implements the same functions over a scripted stream.

fn main() {
    println!("cargo:rerun-if-changed=mock/caer_mock.c");
    if std::env::var_os("CARGO_FEATURE_MOCK").is_some() {
        #[cfg(feature = "mock")]
        cc::Build::new()
            .file("mock/caer_mock.c")
            .warnings(true)
            .compile("caer_mock");
        return;
    }
    if let Err(e) = pkg_config::Config::new()
        .atleast_version("3.0")
        .probe("libcaer")
    {
        panic!(
            "libcaer (>= 3.0) not found through pkg-config: {e}\n\
             Install iniVation's libcaer, or build faithd without the `caer` feature."
        );
    }
}
