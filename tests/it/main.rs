//! The integration tests, one binary: each module tests one area against values the code did
//! not produce (hand-worked numbers, finite differences, certified data, peer programs).
//! Run all with `cargo test --release`; one area with `cargo test --release --test it fit::`.

mod abc;
mod albedo;
mod bounded;
mod choose;
mod cli;
mod cli_fit;
mod cli_hints;
mod common;
mod conserve;
mod corners;
mod corpus;
mod export;
mod fit;
mod fit_models;
mod flip;
mod ggx;
mod ggx2;
mod intervals;
mod inverse;
mod loaders;
mod metal;
mod model_props;
mod mutation;
mod nbrdf;
mod nist;
mod nothing_lost;
mod physical_choose;
mod pixel_refit;
mod plot_outputs;
mod plots;
mod prior;
mod reference;
mod render;
mod render_aa;
mod report;
mod rgl;
mod robustness;
mod scale_free;
mod scene_mutations;
mod study;
mod tabulated;
mod truth;
mod truth_two_abc;
mod wald;
