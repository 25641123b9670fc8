//! `brdfit`: the command-line interface, a thin layer over the library (`src/cli/`).

mod cli;

/// mimalloc keeps freed pages for reuse: repeated fits (several channels, `--model all`,
/// `--repeat`) do not fault fresh pages in on every pass as glibc malloc does after trimming.
/// Built without transparent huge pages (Cargo.toml), whose zeroing cost more than it saved.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    cli::main()
}
