//! Real servers on 127.0.0.1 for the remote cache's tests and benchmark: started on free
//! ports in a folder of their own, stopped when dropped. Each runs under `timeout`, so it also
//! stops by itself should the process that started it die without dropping it.

// The test and the benchmark each use a part.
#![allow(dead_code)]

use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A server process, stopped when dropped. Each runs under `timeout`, so it also stops by
/// itself should this test process die without dropping it.
pub struct Server {
    name: &'static str,
    child: Child,
    log: PathBuf,
    stopped: bool,
}

impl Server {
    pub fn start(name: &'static str, program: &str, args: &[&str], dir: &Path) -> Server {
        let path = which(program);
        std::fs::create_dir_all(dir).unwrap();
        let log = dir.join(format!("{name}.log"));
        let log_file = std::fs::File::create(&log).unwrap();
        // -k: KILL 10 s after the first TERM (ours from `stop`, or the 600 s deadline's): a
        // SeaweedFS that never got going (a disk too full for one volume) hung in its shutdown,
        // and `stop`'s wait with it, for good.
        let child = Command::new("timeout")
            .args(["-k", "10", "-s", "TERM", "600"])
            .arg(&path)
            .args(args)
            .current_dir(dir)
            .stdin(Stdio::null())
            .stdout(log_file.try_clone().unwrap())
            .stderr(log_file)
            .spawn()
            .unwrap_or_else(|e| panic!("starting {name}: {e}"));
        Server {
            name,
            child,
            log,
            stopped: false,
        }
    }

    /// Waits until `port` accepts connections.
    pub fn wait(&mut self, port: u16) {
        let deadline = Instant::now() + Duration::from_secs(60);
        while Instant::now() < deadline {
            if TcpStream::connect(("127.0.0.1", port)).is_ok() {
                return;
            }
            if let Ok(Some(status)) = self.child.try_wait() {
                panic!(
                    "{} exited ({status}) before listening on {port}: {}",
                    self.name,
                    std::fs::read_to_string(&self.log).unwrap_or_default()
                );
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        panic!(
            "{} not listening on {port} after 60 s: {}",
            self.name,
            std::fs::read_to_string(&self.log).unwrap_or_default()
        );
    }

    pub fn stop(&mut self) {
        if std::mem::replace(&mut self.stopped, true) {
            return;
        }
        // TERM, which `timeout` passes on to the server; KILL would stop only `timeout`.
        let _ = Command::new("kill")
            .arg(self.child.id().to_string())
            .stderr(Stdio::null())
            .status();
        let _ = self.child.wait();
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop();
    }
}

pub fn which(program: &str) -> PathBuf {
    let found = std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .chain([PathBuf::from("/usr/sbin"), PathBuf::from("/sbin")])
            .map(|d| d.join(program))
            .find(|p| p.is_file())
    });
    found.unwrap_or_else(|| {
        panic!("{program} is not installed: run scripts/install-test-deps.sh (as root)")
    })
}

pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Redis with a password, nothing saved to disk. Returns the port.
pub fn redis(dir: &Path, password: &str) -> (Server, u16) {
    let port = free_port();
    let port_s = port.to_string();
    let mut s = Server::start(
        "redis",
        "redis-server",
        &[
            "--port",
            &port_s,
            "--bind",
            "127.0.0.1",
            "--save",
            "",
            "--appendonly",
            "no",
            "--requirepass",
            password,
        ],
        dir,
    );
    s.wait(port);
    (s, port)
}

/// An nginx serving WebDAV under `dir/dav`, refusing writes (403) to the bearer of the token
/// `read-only`.
pub fn nginx(dir: &Path) -> (Server, u16) {
    let port = free_port();
    for sub in ["dav", "tmp", "logs"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    let module = ["/usr/lib/nginx/modules/ngx_http_dav_ext_module.so"]
        .into_iter()
        .find(|m| Path::new(m).exists())
        .expect("nginx's WebDAV module: run scripts/install-test-deps.sh");
    let d = dir.display();
    let conf = format!(
        r#"load_module {module};
daemon off;
master_process off;
worker_processes 1;
pid {d}/nginx.pid;
error_log {d}/logs/error.log warn;
events {{ worker_connections 64; }}
http {{
  access_log off;
  client_body_temp_path {d}/tmp;
  proxy_temp_path {d}/tmp;
  fastcgi_temp_path {d}/tmp;
  uwsgi_temp_path {d}/tmp;
  scgi_temp_path {d}/tmp;
  client_max_body_size 0;
  server {{
    listen 127.0.0.1:{port};
    root {d}/dav;
    location / {{
      set $deny "";
      if ($http_authorization = "Bearer read-only") {{ set $deny "r"; }}
      if ($request_method ~ ^(PUT|DELETE|MKCOL|COPY|MOVE)$) {{ set $deny "${{deny}}w"; }}
      if ($deny = "rw") {{ return 403; }}
      dav_methods PUT DELETE MKCOL COPY MOVE;
      dav_ext_methods PROPFIND OPTIONS;
      create_full_put_path on;
      dav_access user:rw group:rw all:r;
    }}
  }}
}}
"#
    );
    std::fs::write(dir.join("nginx.conf"), conf).unwrap();
    let conf = dir.join("nginx.conf").display().to_string();
    let prefix = dir.display().to_string();
    let mut s = Server::start("nginx", "nginx", &["-c", &conf, "-p", &prefix], dir);
    s.wait(port);
    (s, port)
}

/// SeaweedFS with two identities: `ci` may write, `dev` only read. Returns the S3 port.
pub fn seaweed(dir: &Path) -> (Server, u16) {
    std::fs::create_dir_all(dir.join("data")).unwrap();
    std::fs::write(
        dir.join("s3.json"),
        r#"{"identities":[
  {"name":"ci","credentials":[{"accessKey":"ci","secretKey":"ci-secret-5d1e"}],
   "actions":["Admin","Read","Write","List","Tagging"]},
  {"name":"dev","credentials":[{"accessKey":"dev","secretKey":"dev-secret-77aa"}],
   "actions":["Read","List"]}]}"#,
    )
    .unwrap();
    // Every port given: the defaults (gRPC ports at +10000) may collide or overflow.
    let ports: Vec<String> = (0..10).map(|_| free_port().to_string()).collect();
    let arg = |k: &str, v: &str| format!("-{k}={v}");
    let args = [
        "mini".to_string(),
        arg("dir", &dir.join("data").display().to_string()),
        arg("ip", "127.0.0.1"),
        arg("ip.bind", "127.0.0.1"),
        arg("master.telemetry", "false"),
        arg("master.port", &ports[0]),
        arg("volume.port", &ports[1]),
        arg("filer.port", &ports[2]),
        arg("s3.port", &ports[3]),
        arg("admin.port", &ports[4]),
        arg("master.port.grpc", &ports[5]),
        arg("volume.port.grpc", &ports[6]),
        arg("filer.port.grpc", &ports[7]),
        arg("s3.port.grpc", &ports[8]),
        arg("admin.port.grpc", &ports[9]),
        arg("s3.port.iceberg", "0"),
        arg("s3.port.lance", "0"),
        arg("webdav", "false"),
        arg("admin.ui", "false"),
        arg("s3.config", &dir.join("s3.json").display().to_string()),
        arg("bucket", "cache"),
    ];
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let mut s = Server::start("weed", "weed", &args, dir);
    let s3: u16 = ports[3].parse().unwrap();
    s.wait(s3);
    // Listening comes before the bucket exists, and the first write allocates a volume
    // (seconds, sometimes answered 500): wait until a write of a megabyte goes through.
    let warm = dir.join("warm-up.bin");
    std::fs::write(&warm, vec![7u8; 1 << 20]).unwrap();
    let deadline = Instant::now() + Duration::from_secs(90);
    loop {
        let o = Command::new("curl")
            .args([
                "-s",
                "-o",
                "/dev/null",
                "-w",
                "%{http_code}",
                "--max-time",
                "30",
            ])
            .args([
                "--aws-sigv4",
                "aws:amz:us-east-1:s3",
                "--user",
                "ci:ci-secret-5d1e",
            ])
            .args(["-H", "x-amz-content-sha256: UNSIGNED-PAYLOAD", "-T"])
            .arg(&warm)
            .arg(format!("http://127.0.0.1:{s3}/cache/warm-up.bin"))
            .output()
            .expect("curl: run scripts/install-test-deps.sh");
        if o.stdout == b"200" {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "SeaweedFS never took a write: {}",
            std::fs::read_to_string(&s.log).unwrap_or_default()
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    (s, s3)
}
