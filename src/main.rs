//! The `photon` binary: a thin shell around the library; see `cli`.

mod bench;
mod cli;
mod view;

fn main() {
    // Rust ignores SIGPIPE, so printing to a closed pipe (`photon compare a b | head -1`) would
    // panic; restore the default action, which ends the process quietly like any Unix tool.
    // SAFETY: called before any thread starts; SIG_DFL is a valid handler for SIGPIPE.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    std::process::exit(cli::main());
}
