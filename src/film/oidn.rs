//! Intel Open Image Denoise loaded at run time (libloading): the ten C entry points of its
//! 2.x API (`OpenImageDenoise/oidn.h`) that denoising on the CPU device with shared host
//! images needs, so that every build has the denoiser wherever the library is found and
//! nothing is needed to build. OIDN's core library looks for its device modules only in its
//! own folder and the CPU module needs TBB: TBB and the core library are loaded by full path
//! first, so a folder of any name works (pip's pyoidn wheel relies on its folder being
//! named `lib`). Loaded once and never unloaded (OIDN keeps its modules and TBB's threads).

use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The environment variable naming the folder that holds libOpenImageDenoise.so.2 (or the
/// install prefix whose lib/ holds it, as OIDN's own builds use it).
pub const DIR_VAR: &str = "OIDN_DIR";

/// The one command that installs the library where it is found without settings: a Python
/// virtual environment holding pip's pyoidn wheel (OIDN 2.5.1 for the CPU, with TBB), in
/// the user's data folder.
pub const INSTALL: &str =
    "python3 -m venv ~/.local/share/lucent/oidn && ~/.local/share/lucent/oidn/bin/pip install pyoidn==2.5.1.0";

/// OIDN_DEVICE_TYPE_CPU, OIDN_FORMAT_FLOAT3 (oidn.h).
const DEVICE_CPU: c_int = 1;
const FORMAT_FLOAT3: c_int = 3;

/// The library's file name (its SONAME: OIDN 2.x; 1.x has another API and is `.so.1`).
const API: &str = "libOpenImageDenoise.so.2";

type Handle = *mut c_void;

/// The library and its entry points; the libraries are kept alive with the pointers.
struct Oidn {
    _libraries: Vec<libloading::Library>,
    new_device: unsafe extern "C" fn(c_int) -> Handle,
    commit_device: unsafe extern "C" fn(Handle),
    get_device_error: unsafe extern "C" fn(Handle, *mut *const c_char) -> c_int,
    release_device: unsafe extern "C" fn(Handle),
    new_filter: unsafe extern "C" fn(Handle, *const c_char) -> Handle,
    set_shared_filter_image:
        unsafe extern "C" fn(Handle, *const c_char, *mut c_void, c_int, usize, usize, usize, usize, usize),
    set_filter_bool: unsafe extern "C" fn(Handle, *const c_char, bool),
    commit_filter: unsafe extern "C" fn(Handle),
    execute_filter: unsafe extern "C" fn(Handle),
    release_filter: unsafe extern "C" fn(Handle),
}

/// Where the library may be: a folder, or the system's loader (by its name alone).
#[derive(Debug, PartialEq)]
enum Place {
    Folder(PathBuf),
    System,
}

/// The places searched, in order: `OIDN_DIR` alone when it is set (the folder, then its
/// lib/); otherwise the binary's folder, the system's loader (LD_LIBRARY_PATH, ld.so.cache),
/// then a pyoidn wheel in the README's environment, the active virtual or conda
/// environment, the user's site-packages and /usr/local's.
fn places(env: &dyn Fn(&str) -> Option<std::ffi::OsString>) -> Vec<Place> {
    if let Some(dir) = env(DIR_VAR).filter(|d| !d.is_empty()) {
        let dir = PathBuf::from(dir);
        return vec![Place::Folder(dir.clone()), Place::Folder(dir.join("lib"))];
    }
    let mut out = Vec::new();
    if let Some(dir) = std::env::current_exe().ok().and_then(|e| e.parent().map(Path::to_path_buf)) {
        out.push(Place::Folder(dir));
    }
    out.push(Place::System);
    let wheels = |prefix: PathBuf| -> Vec<Place> {
        let Ok(entries) = std::fs::read_dir(prefix.join("lib")) else { return Vec::new() };
        let mut found: Vec<PathBuf> = entries
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with("python3"))
            .flat_map(|e| ["site-packages", "dist-packages"].map(|s| e.path().join(s).join("pyoidn/oidn/lib")))
            .filter(|p| p.is_dir())
            .collect();
        found.sort();
        found.into_iter().map(Place::Folder).collect()
    };
    let home = env("HOME").map(PathBuf::from);
    let data = env("XDG_DATA_HOME").map(PathBuf::from).or_else(|| home.as_ref().map(|h| h.join(".local/share")));
    if let Some(data) = data {
        out.extend(wheels(data.join("lucent/oidn")));
    }
    for var in ["VIRTUAL_ENV", "CONDA_PREFIX"] {
        if let Some(prefix) = env(var) {
            out.extend(wheels(PathBuf::from(prefix)));
        }
    }
    if let Some(home) = home {
        out.extend(wheels(home.join(".local")));
    }
    out.extend(wheels(PathBuf::from("/usr/local")));
    out
}

/// The first file in `dir` whose name starts with `prefix`.
fn file_starting(dir: &Path, prefix: &str) -> Option<PathBuf> {
    let mut names: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with(prefix)))
        .collect();
    names.sort();
    names.into_iter().next()
}

impl Oidn {
    /// Loads the library from `place`: in a folder, TBB and the core library first by full
    /// path (OIDN's core looks for its device modules beside itself); from the system's
    /// loader by name.
    fn load(place: &Place) -> Result<Self, String> {
        let mut libraries = Vec::new();
        let api = match place {
            Place::System => PathBuf::from(API),
            Place::Folder(dir) => {
                let api = dir.join(API);
                if !api.is_file() {
                    return Err(format!("no {API} in {}", dir.display()));
                }
                for prefix in ["libtbb.so.12", "libOpenImageDenoise_core.so.2"] {
                    if let Some(path) = file_starting(dir, prefix) {
                        // SAFETY: loading runs the library's initialisers; these are OIDN's own
                        // dependencies from its distribution, loaded as its API library would load them.
                        libraries.push(unsafe { libloading::Library::new(&path) }.map_err(|e| e.to_string())?);
                    }
                }
                api
            }
        };
        // SAFETY: as above, for the API library itself.
        let library = unsafe { libloading::Library::new(&api) }.map_err(|e| e.to_string())?;
        macro_rules! symbol {
            ($name:literal) => {
                // SAFETY: the symbol's type is its C signature in oidn.h (2.x).
                *unsafe { library.get(concat!($name, "\0").as_bytes()) }.map_err(|e| format!("{}: {e}", $name))?
            };
        }
        let oidn = Self {
            new_device: symbol!("oidnNewDevice"),
            commit_device: symbol!("oidnCommitDevice"),
            get_device_error: symbol!("oidnGetDeviceError"),
            release_device: symbol!("oidnReleaseDevice"),
            new_filter: symbol!("oidnNewFilter"),
            set_shared_filter_image: symbol!("oidnSetSharedFilterImage"),
            set_filter_bool: symbol!("oidnSetFilterBool"),
            commit_filter: symbol!("oidnCommitFilter"),
            execute_filter: symbol!("oidnExecuteFilter"),
            release_filter: symbol!("oidnReleaseFilter"),
            _libraries: Vec::new(),
        };
        libraries.push(library);
        Ok(Self { _libraries: libraries, ..oidn })
    }

    /// The library from the first place that has it, loaded on first use; or one line
    /// saying what was wrong with the folder named, or what to run.
    fn get() -> Result<&'static Self, String> {
        static OIDN: OnceLock<Result<Oidn, String>> = OnceLock::new();
        OIDN.get_or_init(|| {
            let named = std::env::var_os(DIR_VAR).filter(|d| !d.is_empty()).map(PathBuf::from);
            find(&places(&|v| std::env::var_os(v)), named.as_deref())
        })
        .as_ref()
        .map_err(Clone::clone)
    }

    /// The device's pending error as one line, if any.
    fn error(&self, device: Handle) -> Result<(), String> {
        let mut message: *const c_char = std::ptr::null();
        // SAFETY: `device` is null or a live device; OIDN keeps the message until the next call.
        let code = unsafe { (self.get_device_error)(device, &mut message) };
        if code == 0 {
            return Ok(());
        }
        let text = if message.is_null() {
            String::new()
        } else {
            // SAFETY: OIDN returns a NUL-terminated string.
            unsafe { CStr::from_ptr(message) }.to_string_lossy().replace('\n', " ")
        };
        const KINDS: [&str; 7] = [
            "none",
            "unknown error",
            "invalid argument",
            "invalid operation",
            "out of memory",
            "unsupported hardware",
            "cancelled",
        ];
        let kind = KINDS.get(code as usize).copied().unwrap_or("error");
        Err(format!("Open Image Denoise: {kind}: {text}"))
    }

    /// Runs `f` on a new, committed CPU device, released afterwards.
    fn with_device<T>(&self, f: impl FnOnce(Handle) -> Result<T, String>) -> Result<T, String> {
        // SAFETY: the device is checked for null before use and released once, after `f`.
        unsafe {
            let device = (self.new_device)(DEVICE_CPU);
            if device.is_null() {
                self.error(std::ptr::null_mut())?;
                return Err("Open Image Denoise: no CPU device".into());
            }
            (self.commit_device)(device);
            let result = self.error(device).and_then(|()| f(device));
            (self.release_device)(device);
            result
        }
    }

    /// Whether a CPU device can be made (the library loads without its device module or
    /// TBB, and only making a device finds out).
    fn check_device(&self) -> Result<(), String> {
        self.with_device(|_| Ok(()))
    }
}

/// The library from the first of `places` that loads and makes a CPU device, or one line:
/// with a folder `named` (`OIDN_DIR`), why it did not load; otherwise the command that
/// installs it.
fn find(places: &[Place], named: Option<&Path>) -> Result<Oidn, String> {
    let mut failures = Vec::new();
    for place in places {
        match Oidn::load(place).and_then(|oidn| oidn.check_device().map(|()| oidn)) {
            Ok(oidn) => return Ok(oidn),
            Err(e) => failures.push(e.replace('\n', " ")),
        }
    }
    Err(match named {
        Some(dir) => {
            format!("Open Image Denoise did not load from {DIR_VAR}={} ({})", dir.display(), failures.join("; "))
        }
        None => format!("Open Image Denoise is not installed; to install it, run: {INSTALL}"),
    })
}

/// Whether the library is found and makes a CPU device, or one line saying why not and what
/// to run.
pub fn available() -> Result<(), String> {
    Oidn::get().map(|_| ())
}

/// Runs the `RT` filter on the CPU device over the row-major `width` x `height` RGB images
/// (f32 triples): `color` (HDR) into the result, guided by `albedo` and `normal` if given.
pub fn filter(color: &[f32], guide: Option<(&[f32], &[f32])>, width: usize, height: usize) -> Result<Vec<f32>, String> {
    let oidn = Oidn::get()?;
    let mut output = vec![0.0f32; color.len()];
    oidn.with_device(|device| {
        // SAFETY: the filter is released once; the images outlive its execution, which is
        // synchronous, and hold width x height f32 triples.
        unsafe {
            let rt = CString::new("RT").expect("no NUL");
            let filter = (oidn.new_filter)(device, rt.as_ptr());
            oidn.error(device)?;
            let set = |name: &str, data: *const f32| {
                let name = CString::new(name).expect("no NUL");
                let format = FORMAT_FLOAT3;
                (oidn.set_shared_filter_image)(
                    filter,
                    name.as_ptr(),
                    data as *mut c_void,
                    format,
                    width,
                    height,
                    0,
                    0,
                    0,
                );
            };
            set("color", color.as_ptr());
            if let Some((albedo, normal)) = guide {
                set("albedo", albedo.as_ptr());
                set("normal", normal.as_ptr());
            }
            set("output", output.as_mut_ptr());
            let hdr = CString::new("hdr").expect("no NUL");
            (oidn.set_filter_bool)(filter, hdr.as_ptr(), true);
            (oidn.commit_filter)(filter);
            let run = oidn.error(device).and_then(|()| {
                (oidn.execute_filter)(filter);
                oidn.error(device)
            });
            (oidn.release_filter)(filter);
            run
        }
    })?;
    Ok(output)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::OsString;

    /// An environment of the given variables only.
    fn env_of(vars: &[(&str, &Path)]) -> impl Fn(&str) -> Option<OsString> + use<> {
        let vars: Vec<(String, OsString)> = vars.iter().map(|(k, v)| (k.to_string(), v.as_os_str().into())).collect();
        move |name| vars.iter().find(|(k, _)| k == name).map(|(_, v)| v.clone())
    }

    #[test]
    fn the_library_found_denoises_noise_or_says_in_one_line_how_to_install_it() {
        let (w, h) = (32, 32);
        let mut state = 1u64;
        let noisy: Vec<f32> = (0..3 * w * h)
            .map(|_| {
                state = crate::math::sampler::mix64(state);
                0.5 + ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5)
            })
            .collect();
        match filter(&noisy, None, w, h) {
            Ok(out) => {
                let var = |v: &[f32]| v.iter().map(|x| (x - 0.5) * (x - 0.5)).sum::<f32>() / v.len() as f32;
                assert!(var(&out) < var(&noisy) / 10.0, "{} -> {}", var(&noisy), var(&out));
            }
            Err(e) => {
                assert!(std::env::var_os("LUCENT_REQUIRE_OIDN").is_none(), "LUCENT_REQUIRE_OIDN is set: {e}");
                let named = std::env::var_os(DIR_VAR).is_some_and(|d| !d.is_empty());
                assert!(!e.contains('\n') && (named || e.ends_with(INSTALL)), "{e}");
            }
        }
    }

    #[test]
    fn a_folder_named_by_oidn_dir_is_the_only_place_searched() {
        let env = env_of(&[(DIR_VAR, Path::new("/opt/oidn")), ("HOME", Path::new("/home/x"))]);
        let want = [Place::Folder("/opt/oidn".into()), Place::Folder("/opt/oidn/lib".into())];
        assert_eq!(places(&env), want);
    }

    #[test]
    fn the_readme_environment_is_searched_before_the_active_one_and_after_the_system() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path();
        let wheel = |prefix: &Path| prefix.join("lib/python3.11/site-packages/pyoidn/oidn/lib");
        let (readme, active) = (dir.join("data/lucent/oidn"), dir.join("venv"));
        for prefix in [&readme, &active] {
            std::fs::create_dir_all(wheel(prefix)).unwrap();
        }
        let found = places(&env_of(&[("XDG_DATA_HOME", &dir.join("data")), ("VIRTUAL_ENV", &active)]));
        let at = |p: &Place| found.iter().position(|q| q == p).unwrap_or_else(|| panic!("{p:?} not in {found:?}"));
        assert!(at(&Place::System) < at(&Place::Folder(wheel(&readme))));
        assert!(at(&Place::Folder(wheel(&readme))) < at(&Place::Folder(wheel(&active))));
    }

    #[test]
    fn a_folder_without_a_working_library_is_refused_in_one_line_that_names_it() {
        let scratch = tempfile::tempdir().unwrap();
        let dir = scratch.path().to_path_buf();
        let failed = find(&[Place::Folder(dir.clone())], None).err().unwrap();
        assert!(failed.ends_with(INSTALL) && !failed.contains('\n'), "{failed}");
        std::fs::write(dir.join(API), "not a library\n").unwrap();
        let failed = find(&[Place::Folder(dir.clone())], Some(&dir)).err().unwrap();
        assert!(failed.contains(&dir.display().to_string()) && !failed.contains('\n'), "{failed}");
        assert!(failed.contains("OIDN_DIR") && failed.contains(API), "{failed}");
    }
}
