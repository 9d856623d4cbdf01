//! Generates the gRPC server and client (`caustic.v1`) from proto/caustic.proto with
//! the vendored protoc, so building needs no protoc installed.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    const PROTO: &str = "proto/caustic.proto";
    println!("cargo:rerun-if-changed={PROTO}");
    println!("cargo:rerun-if-changed=build.rs");
    let mut config = tonic_prost_build::Config::new();
    config.protoc_executable(protoc_bin_vendored::protoc_bin_path()?);
    tonic_prost_build::configure()
        .emit_rerun_if_changed(false)
        .compile_with_config(config, &[PROTO], &["proto"])?;
    Ok(())
}
