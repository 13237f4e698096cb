use clap::Parser;
use tracing_subscriber::EnvFilter;

fn main() {
    keep_freed_memory();
    tracing_subscriber::fmt()
        .with_env_filter(EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("info")))
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .init();
    if let Err(e) = wedge::cli::run(wedge::cli::Cli::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

/// A render allocates its per-pixel buffers afresh, and glibc's defaults hand freed blocks of
/// more than 128 KiB (and free space over 128 KiB at the top of a heap) back to the kernel at
/// once: the next render, a new view in a session or the next request, then pays a page fault
/// and a zeroed page for every page again (BENCHMARKS.md, "Latency", has what it costs). Blocks
/// up to 32 MiB (glibc's limit for this setting) now come from the heap, and up to 256 MiB of
/// free heap stays mapped for reuse. Either setting given in the environment
/// (`MALLOC_MMAP_THRESHOLD_`, `MALLOC_TRIM_THRESHOLD_`) is left as it is.
fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    for (param, value, env) in [
        (libc::M_MMAP_THRESHOLD, 32 << 20, "MALLOC_MMAP_THRESHOLD_"),
        (libc::M_TRIM_THRESHOLD, 256 << 20, "MALLOC_TRIM_THRESHOLD_"),
    ] {
        if std::env::var_os(env).is_none() {
            // SAFETY: mallopt only changes allocator tuning and is called before any thread
            // starts; on failure (0) the default stays, which is correct, only slower.
            unsafe {
                libc::mallopt(param, value);
            }
        }
    }
}
