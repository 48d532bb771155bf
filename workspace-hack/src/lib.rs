//! No code: a crate that exists for its manifest. Its dependencies turn on, for every build of
//! the workspace, the features that numpy (the Python wheel), proptest (the tests) and
//! async-opcua (`twin serve`) would otherwise turn on only in some builds, in dependencies they
//! share with the Rerun stack and nalgebra (tokio, getrandom, digest, smallvec, …). Without it,
//! each entry point (`cargo test --workspace`, `cargo run -p twin-cli`, `cargo install`, the
//! wheel's maturin build) resolved other features and recompiled the Rerun stack. The engine's
//! own manifest then lists only what the engine uses; this crate is one of its dev-dependencies,
//! for its tests and examples, and a dependency of the applications.
