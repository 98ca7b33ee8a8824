//! With the `mock` feature, builds the two C test doubles as shared libraries that
//! tests load exactly as faithd loads libcaer: the mock of libcaer in `mock/`
//! (`$OUT_DIR/libcaer_mock.so`), and the USB stand-in in `usb_standin/`
//! (`$OUT_DIR/libusb_standin.so`), a camera on a pretend bus that iniVation's real
//! libcaer drives through libusb's API when the stand-in is preloaded. Nothing is
//! linked: libcaer itself is opened at run time.

fn main() {
    println!("cargo:rerun-if-changed=mock/caer_mock.c");
    println!("cargo:rerun-if-changed=usb_standin/usb_standin.c");
    #[cfg(feature = "mock")]
    {
        let out = std::path::PathBuf::from(std::env::var_os("OUT_DIR").expect("OUT_DIR"));
        let compiler = cc::Build::new().warnings(true).get_compiler();
        let shared = |source: &str, library: &str| {
            let status = compiler
                .to_command()
                .args([
                    "-shared", "-fPIC", "-pthread", "-O2", "-Wall", "-Wextra", "-o",
                ])
                .arg(out.join(library))
                .arg(source)
                .status()
                .expect("run the C compiler");
            assert!(status.success(), "building {source} failed");
        };
        shared("mock/caer_mock.c", "libcaer_mock.so");
        shared("usb_standin/usb_standin.c", "libusb_standin.so");
        // The stand-in declares libusb's types itself (no libusb headers needed to
        // build it); where libusb.h is installed, the same file compiles against it
        // too, which holds every declaration and signature to libusb's own.
        let header = std::path::Path::new("/usr/include/libusb-1.0/libusb.h");
        println!("cargo:rerun-if-changed={}", header.display());
        if header.exists() {
            let status = compiler
                .to_command()
                .args([
                    "-fsyntax-only",
                    "-Wall",
                    "-Wextra",
                    "-Werror",
                    "-DUSB_STANDIN_SYSTEM_LIBUSB",
                ])
                .arg("usb_standin/usb_standin.c")
                .status()
                .expect("run the C compiler");
            assert!(
                status.success(),
                "usb_standin.c does not match the system's libusb.h"
            );
        }
    }
}
