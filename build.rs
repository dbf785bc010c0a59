//! Records the git revision the binary was built from (when built from a
//! checkout) as `SLOTHSIM_GIT_REV`, for the provenance block of every output.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    // Re-run when HEAD moves, the index changes or sources change (for the
    // `-dirty` mark); a build outside a checkout records no revision.
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=crates");
    println!("cargo:rerun-if-changed=Cargo.toml");
    if let Some(dir) = git(&["rev-parse", "--git-dir"]) {
        println!("cargo:rerun-if-changed={dir}/HEAD");
        println!("cargo:rerun-if-changed={dir}/index");
    }
    if let Some(common) = git(&["rev-parse", "--git-common-dir"])
        && let Some(head_ref) = git(&["symbolic-ref", "-q", "HEAD"])
    {
        println!("cargo:rerun-if-changed={common}/{head_ref}");
    }
    if let Some(rev) = git(&["rev-parse", "HEAD"]) {
        let dirty =
            git(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
        let mark = if dirty { "-dirty" } else { "" };
        println!("cargo:rustc-env=SLOTHSIM_GIT_REV={rev}{mark}");
    }
}
