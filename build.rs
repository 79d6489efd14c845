//! With the `denoise` feature and OIDN_DIR set (the folder whose lib/ holds
//! libOpenImageDenoise, e.g. pip's pyoidn/oidn), records that lib/ as a run-time search path
//! of every binary and test, so they run without LD_LIBRARY_PATH. The `oidn` crate itself
//! only adds the link-time path.

fn main() {
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    if std::env::var_os("CARGO_FEATURE_DENOISE").is_none() {
        return;
    }
    if let Some(dir) = std::env::var_os("OIDN_DIR").filter(|d| !d.is_empty()) {
        let lib = std::path::Path::new(&dir).join("lib");
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
    }
}
