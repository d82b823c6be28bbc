//! The `photon` binary: a thin shell around the library; see `cli`.

mod bench;
mod cli;

fn main() {
    std::process::exit(cli::main());
}
