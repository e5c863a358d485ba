//! The `wavetrace` command line. The subcommands live in [`cli`]; this file turns what
//! they return into the exit status: 0, 130 for a render that Ctrl-C cut short, and for
//! an error its message on stderr with 2 (bad input) or 1 (internal error).

mod cli;

use clap::Parser;

fn main() {
    match cli::run(cli::Cli::parse()) {
        Ok(0) => {}
        Ok(code) => std::process::exit(code),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(e.exit_code());
        }
    }
}
