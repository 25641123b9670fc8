//! `brdfit`: the command-line interface, a thin layer over the library (`src/cli/`).

mod cli;

fn main() -> std::process::ExitCode {
    brdfit::keep_freed_memory();
    cli::main()
}
