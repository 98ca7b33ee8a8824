//! With the `mock` feature, builds the C mock in `mock/` as a shared library
//! (`$OUT_DIR/libcaer_mock.so`) that tests load exactly as faithd loads libcaer.
//! Nothing is linked: libcaer itself is opened at run time.

fn main() {
    println!("cargo:rerun-if-changed=mock/caer_mock.c");
    #[cfg(feature = "mock")]
    {
        let out = std::path::PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR"));
        let library = out.join("libcaer_mock.so");
        let compiler = cc::Build::new().warnings(true).get_compiler();
        let status = compiler
            .to_command()
            .args([
                "-shared", "-fPIC", "-pthread", "-O2", "-Wall", "-Wextra", "-o",
            ])
            .arg(&library)
            .arg("mock/caer_mock.c")
            .status()
            .expect("run the C compiler");
        assert!(status.success(), "building the libcaer mock failed");
    }
}
