//! What every sweep shares: the machine description, median timing, deterministic test data.

use std::time::Instant;

use serde::{Deserialize, Serialize};

/// Where and how the numbers were taken.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Machine {
    pub cpu: String,
    /// Logical CPUs this process may use.
    pub cores: usize,
    pub profile: String,
    /// UTC, when the run started.
    pub date: String,
    /// `rustc` jobs running when the run started: other builds make the timings noisy.
    pub concurrent_rustc: Option<usize>,
}

impl Machine {
    pub fn detect() -> Self {
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split_once(':'))
                    .map(|(_, v)| v.trim().to_string())
            })
            .unwrap_or_else(|| "unknown".into());
        Self {
            cpu,
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            profile: if cfg!(debug_assertions) {
                "debug (numbers not representative)"
            } else {
                "release"
            }
            .to_string(),
            date: utc_now(),
            concurrent_rustc: count_processes("rustc"),
        }
    }

    pub fn markdown(&self) -> String {
        let load = match self.concurrent_rustc {
            Some(0) => "no other compilation running at the start".to_string(),
            Some(n) => {
                format!("**{n} rustc process(es) running at the start: timings taken under load**")
            }
            None => "load unknown".to_string(),
        };
        format!(
            "Machine: {}, {} logical cores; build profile: {}; {}; {}.",
            self.cpu, self.cores, self.profile, self.date, load
        )
    }
}

/// Processes whose command name is `name`, from /proc (Linux only).
fn count_processes(name: &str) -> Option<usize> {
    let dir = std::fs::read_dir("/proc").ok()?;
    let n = dir
        .filter_map(|e| e.ok())
        .filter(|e| {
            e.file_name()
                .to_string_lossy()
                .bytes()
                .all(|b| b.is_ascii_digit())
        })
        .filter(|e| std::fs::read_to_string(e.path().join("comm")).is_ok_and(|c| c.trim() == name))
        .count();
    Some(n)
}

/// The current UTC time as `YYYY-MM-DD HH:MM UTC`.
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Howard Hinnant's civil-from-days.
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02} UTC",
        rem / 3600,
        rem % 3600 / 60
    )
}

/// Runs `f` `runs` times (at least once) and returns the median wall time in ms and the last
/// result.
///
/// A first run under half a second is a warm-up and not counted (thread pool start, page
/// faults of fresh buffers); a slower one counts, since there its share is small and repeating
/// it would cost minutes.
pub fn median_ms<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut times = Vec::with_capacity(runs.max(1));
    let start = Instant::now();
    let mut last = Some(f());
    let first = start.elapsed().as_secs_f64() * 1e3;
    if first >= 500.0 {
        times.push(first);
    }
    while times.len() < runs.max(1) {
        let start = Instant::now();
        let out = f();
        times.push(start.elapsed().as_secs_f64() * 1e3);
        last = Some(out);
    }
    (median(&mut times), last.expect("ran at least once"))
}

pub fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// [`texture::testing::design`] with the blur benchmark's pane grid (61 x 47, leads 3 wide).
pub fn design(w: usize, h: usize, seed: u64) -> Vec<u8> {
    let panes = texture::testing::Panes {
        width: 61,
        height: 47,
        lead: 3,
    };
    texture::testing::design(w, h, seed, panes)
}

/// Formats an optional number for a Markdown table (empty cell when absent).
pub fn cell(v: Option<f64>, digits: usize) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.digits$}"),
        Some(v) => format!("{v}"),
        None => String::new(),
    }
}

/// Mean and 99th percentile of FLIP between two 8-bit sRGB images of `w` x `h` (RGB bytes).
pub fn flip(reference: &[u8], test: &[u8], w: u32, h: u32) -> (f64, f64) {
    let error = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(w, h, reference),
        nv_flip::FlipImageRgb8::with_data(w, h, test),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let mut pool = nv_flip::FlipPool::from_image(&error);
    (pool.mean() as f64, pool.get_percentile(0.99, false) as f64)
}

/// The hidden first argument under which a bench process runs one command for another:
/// `bench --measure-child RESULT PROGRAM ARGS...`.
pub const MEASURE_CHILD: &str = "--measure-child";

/// Runs `cmd` to its end like `Command::output`, and also returns its own wall time in ms and
/// its peak resident memory in bytes. A child's `ru_maxrss` starts from the memory of the
/// process that spawned it (Linux carries the old image's high-water mark across `exec`), and
/// the bench holds hundreds of MB, so the command is started by a fresh, small bench process
/// ([`measure_child`]) that reports both numbers through a file.
pub fn output_with_peak_rss(
    cmd: &mut std::process::Command,
) -> anyhow::Result<(std::process::Output, f64, u64)> {
    use anyhow::Context;
    let result = tempfile_path("measure");
    let mut outer = std::process::Command::new(std::env::current_exe()?);
    outer
        .arg(MEASURE_CHILD)
        .arg(&result)
        .arg(cmd.get_program())
        .args(cmd.get_args());
    for (k, v) in cmd.get_envs() {
        match v {
            Some(v) => outer.env(k, v),
            None => outer.env_remove(k),
        };
    }
    if let Some(dir) = cmd.get_current_dir() {
        outer.current_dir(dir);
    }
    let out = outer
        .stdin(std::process::Stdio::null())
        .output()
        .with_context(|| format!("running {:?}", cmd.get_program()))?;
    let text = std::fs::read_to_string(&result);
    let _ = std::fs::remove_file(&result);
    let text = text.with_context(|| format!("no measurement of {:?}", cmd.get_program()))?;
    let mut it = text.split_whitespace();
    let ms: f64 = it.next().context("no time")?.parse()?;
    let rss: u64 = it.next().context("no peak memory")?.parse()?;
    Ok((out, ms, rss))
}

fn tempfile_path(what: &str) -> std::path::PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    std::env::temp_dir().join(format!(
        "bench-{what}-{}-{}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ))
}

/// The `--measure-child` side: runs `args` (`RESULT PROGRAM ARGS...`) with this process's
/// standard streams, writes "`<wall ms> <peak RSS bytes>`" to RESULT and returns the exit code
/// to leave with.
pub fn measure_child(args: &[std::ffi::OsString]) -> anyhow::Result<i32> {
    use anyhow::Context;
    let [result, program, rest @ ..] = args else {
        anyhow::bail!("{MEASURE_CHILD} RESULT PROGRAM [ARGS...]");
    };
    let start = Instant::now();
    let child = std::process::Command::new(program)
        .args(rest)
        .spawn()
        .with_context(|| format!("running {program:?}"))?;
    let mut status = 0;
    // SAFETY: an all-zero rusage is valid; wait4 reaps this child, which std never waits for.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::wait4(child.id() as libc::pid_t, &mut status, 0, &mut usage) } < 0 {
        return Err(std::io::Error::last_os_error().into());
    }
    let ms = start.elapsed().as_secs_f64() * 1e3;
    std::fs::write(result, format!("{ms} {}", usage.ru_maxrss as u64 * 1024))?;
    Ok(if libc::WIFEXITED(status) {
        libc::WEXITSTATUS(status)
    } else {
        128 + libc::WTERMSIG(status)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_child_run_for_its_peak_memory_keeps_its_output_and_status() {
        let dir = std::env::temp_dir().join(format!("bench-measure-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let result = dir.join("result");
        let args: Vec<std::ffi::OsString> = [
            result.as_os_str(),
            "sh".as_ref(),
            "-c".as_ref(),
            "exit 3".as_ref(),
        ]
        .iter()
        .map(|s| s.to_os_string())
        .collect();
        assert_eq!(measure_child(&args).unwrap(), 3);
        let text = std::fs::read_to_string(&result).unwrap();
        let mut it = text.split_whitespace();
        let ms: f64 = it.next().unwrap().parse().unwrap();
        let peak: u64 = it.next().unwrap().parse().unwrap();
        assert!(ms > 0.0, "{text}");
        // sh needs a few MB; the test process's own memory must not count.
        assert!(peak > 100_000 && peak < 64 << 20, "{peak}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&mut []).is_nan());
    }

    #[test]
    fn utc_date_is_well_formed() {
        let d = utc_now();
        assert_eq!(d.len(), "2026-01-01 00:00 UTC".len(), "{d}");
        assert!(d.starts_with("20"), "{d}");
    }
}
