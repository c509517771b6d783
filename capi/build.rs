//! Generates `include/spmcal.h` from the C interface with cbindgen, so the committed header is
//! always the one the library exports (a test checks that it is unchanged).

fn main() {
    let dir = std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it");
    let config = cbindgen::Config::from_file(format!("{dir}/cbindgen.toml")).expect("capi/cbindgen.toml");
    let header =
        cbindgen::Builder::new().with_crate(&dir).with_config(config).generate().expect("the C interface has a header");
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets it")).join("spmcal.h");
    header.write_to_file(&out);
    println!("cargo:rerun-if-changed=src/lib.rs");
    println!("cargo:rerun-if-changed=cbindgen.toml");
}
