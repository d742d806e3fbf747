//! `vlf-bake`: parses the command line and hands over to the library. Errors are printed once,
//! here, with their full cause chain, and mapped to distinct exit codes (see `vlf_bake::ExitCode`).

use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = vlf_bake::cli::Cli::parse();
    vlf_bake::init_logging(cli.verbose, cli.quiet);
    match vlf_bake::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            vlf_bake::exit_code(&err).into()
        }
    }
}
