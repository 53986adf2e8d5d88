//! The `platoon` binary: the command of [`platoon_cli`].
fn main() -> std::process::ExitCode {
    std::process::ExitCode::from(platoon_cli::main_with(std::env::args_os()))
}
