//! # brdfit
//!
//! Fit reflection models to measured reflectance and analyse the result.
//!
//! The data flows through the modules in order: [`data`] (samples and loaders) →
//! [`model`] (the BRDFs of Phong 1975, Blinn 1977 and GGX–Smith, with analytic gradients) →
//! fit, plot, render, scene, choose and report. [`simulate()`] makes synthetic samples. The items most
//! programs need are re-exported here; [`support`] is the plumbing below them all. Modules marked
//! hidden in these docs (`support::input`, `support::setting`, `fit::lsq`, `fit::problem`,
//! `data::merl`) are public only because the binary and the integration tests are separate
//! crates, and are not library API.
//!
//! Fitting Blinn's Torrance–Sparrow model to a measurement file from Rust (any format
//! [`load`] reads; here the bundled samples of Blinn's magnesium oxide):
//!
//! ```
//! use brdfit::{ChannelSelect, FitOptions, LoadOptions, ModelKind, fit, load};
//!
//! let samples = load("data/blinn-mgo.csv".as_ref(), &LoadOptions::default())?;
//! // One channel of a colour file: samples.select(&ChannelSelect::Name("g".into()))?
//! let samples = samples.select(&ChannelSelect::Index(0))?;
//! let mut options = FitOptions::new(ModelKind::TorranceSparrow);
//! options.verify = 4; // four random starts must not find a lower cost
//! let result = fit(&samples, &options)?.remove(0);
//! assert!(result.usable());
//! assert!((result.get("c3").unwrap() - 0.35).abs() < 0.01);
//! // Each parameter's 95 % confidence interval (profile likelihood):
//! for (name, lo, hi) in &result.ranges {
//!     println!("{name} in [{lo}, {hi}]");
//! }
//! println!("{}", serde_json::to_string_pretty(&result)?);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]
// Numeric code indexes parallel arrays (struct-of-arrays); index loops are the clear form.
#![allow(clippy::needless_range_loop)]
// `!(x <= limit)` is deliberate: it is true for NaN, which must count as failing a test.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

// The data's path: data → model → fit → plot / render → scene → choose → report; support is
// the plumbing below them all.
pub mod choose;
pub mod data;
pub mod export;
pub mod fit;
pub mod inverse;
pub mod model;
pub mod plan;
pub mod plot;
pub mod prior;
pub mod render;
pub mod report;
pub mod scene;
pub mod simulate;
pub mod study;
pub mod support;

/// Tell the C allocator (glibc's malloc) to keep freed memory for reuse, once at the start of
/// a program: blocks up to 32 MB (a million rows' geometry column is 8 MB) come from its heaps
/// rather than from mappings of their own (`M_MMAP_THRESHOLD`), and freed memory is not handed
/// back to the system while the process runs (`M_TRIM_THRESHOLD`). Repeated fits (`--repeat`,
/// several channels, `--model all`, `choose`'s candidates) then reuse pages already touched:
/// a page touched for the first time costs a page fault, 2.7–2.8 µs per 4 KB on the 2-core
/// VM this was measured on (1.8 µs with `MAP_POPULATE`), against about 0.1 µs per 4 KB to
/// rewrite a page already there. With glibc's defaults the thresholds adapt and trim freed
/// memory; mimalloc (the allocator before) kept it but took three to five runs of a fit to
/// reuse its medium blocks. Elsewhere (not glibc) it does nothing.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets two of the allocator's parameters (it takes the allocator's own
    // lock); a value it rejects leaves the default in place.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
    }
}

#[cfg(all(test, target_os = "linux", target_env = "gnu"))]
mod tests {
    /// Minor page faults of the calling thread so far (field 10 of /proc/thread-self/stat).
    fn faults() -> u64 {
        let stat = std::fs::read_to_string("/proc/thread-self/stat").expect("procfs");
        let after_name = stat.rsplit(')').next().expect("a stat line");
        after_name
            .split_whitespace()
            .nth(7)
            .expect("minflt")
            .parse()
            .expect("a count")
    }

    /// Memory freed and asked for again is reused, not faulted in afresh: an 8 MB block
    /// (a million rows' column) written, freed and written again costs no new pages. With
    /// glibc's defaults the first block is mapped on its own and unmapped when freed, and the
    /// second grows the heap by fresh pages: 2,048 faults.
    #[test]
    fn freed_memory_is_reused_without_faults() {
        super::keep_freed_memory();
        let write = || std::hint::black_box(vec![1u8; 8 << 20]).len();
        write();
        let before = faults();
        write();
        let fresh = faults() - before;
        assert!(
            fresh < 256,
            "{fresh} pages faulted in for a block just freed"
        );
    }
}

pub use data::{ChannelSelect, Dataset, LoadOptions, load};
pub use fit::{FitError, FitOptions, FitResult, fit};
pub use model::{Distribution, Geometry, Model, ModelKind};
pub use render::Scene;
pub use report::{ReportOptions, report};
pub use simulate::simulate;
pub use support::setting::Setting;
