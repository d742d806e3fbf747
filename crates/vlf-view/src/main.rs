//! `vlf-view`: parses the command line and hands over to the library. Errors are printed once,
//! here, with their full cause chain, and mapped to distinct exit codes (see
//! `vlf_view::ExitCode`).

use clap::Parser;

fn main() -> std::process::ExitCode {
    let cli = vlf_view::cli::Cli::parse();
    vlf_view::init_logging(cli.verbose, cli.quiet);
    match vlf_view::run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            vlf_view::exit_code(&err).into()
        }
    }
}
