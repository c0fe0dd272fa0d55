//! Links Debian's static CLIPS 6.30 (`libclips-dev`: /usr/lib/libclips.a, headers in
//! /usr/include/clips). `CLIPS_LIB_DIR` points elsewhere.
fn main() {
    let dir = std::env::var("CLIPS_LIB_DIR").unwrap_or_else(|_| "/usr/lib".into());
    let lib = std::path::Path::new(&dir).join("libclips.a");
    if !lib.is_file() {
        panic!(
            "{} not found: install CLIPS with `apt-get install --no-install-recommends libclips-dev` (or set CLIPS_LIB_DIR)",
            lib.display()
        );
    }
    println!("cargo:rerun-if-env-changed=CLIPS_LIB_DIR");
    println!("cargo:rustc-link-search=native={dir}");
    println!("cargo:rustc-link-lib=static=clips");
    println!("cargo:rustc-link-lib=m");
}
