//! `cliff observe`: recorded trajectory files streamed to a learning `cliffd` as
//! observations. The client side of the daemon lives in the `cliff-client` crate, above
//! this one, so the command runs its binary `cliff-observe` (beside this binary, else on
//! `PATH`) with the same arguments.

use std::path::PathBuf;
use std::process::Command;

use anyhow::{Context, Result, bail};
use clap::Args;

/// The arguments, passed to `cliff-observe` as given.
#[derive(Args, Debug)]
#[command(disable_help_flag = true)]
pub struct ObserveArgs {
    /// `cliff-observe`'s arguments (`cliff observe --help` lists them).
    #[arg(trailing_var_arg = true, allow_hyphen_values = true, num_args = 0..)]
    pub args: Vec<String>,
}

/// The `cliff-observe` binary: beside this one, else found on `PATH`.
fn observe_exe() -> PathBuf {
    let beside = std::env::current_exe()
        .ok()
        .map(|e| e.with_file_name("cliff-observe"));
    match beside {
        Some(p) if p.exists() => p,
        _ => PathBuf::from("cliff-observe"),
    }
}

/// Run `cliff observe`.
pub fn run(a: ObserveArgs) -> Result<()> {
    let exe = observe_exe();
    let status = Command::new(&exe).args(&a.args).status().with_context(|| {
        format!(
            "cannot run {} (built by `cargo build --release -p cliff-client --bins`)",
            exe.display()
        )
    })?;
    if !status.success() {
        // cliff-observe has said what went wrong
        bail!("cliff-observe failed ({status})");
    }
    Ok(())
}
