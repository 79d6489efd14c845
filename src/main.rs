//! The `lucent` command: parses arguments and hands over to the CLI.

fn main() -> std::process::ExitCode {
    lucent::cli::main()
}
