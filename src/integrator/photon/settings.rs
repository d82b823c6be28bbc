//! The photon method's settings (one plain struct with documented defaults, which the command
//! line and the add-on map onto) and the statistics of its photon tracing.

/// Photon-mapping settings; the command line maps onto them.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotonSettings {
    /// Photons emitted for the global map (default 200 000).
    pub global_photons: u32,
    /// Photons emitted for the caustic map (default 100 000, aimed at the specular objects).
    pub caustic_photons: u32,
    /// Nearest photons in a global estimate (default 64).
    pub k_global: u32,
    /// Nearest photons in a caustic estimate (default 64).
    pub k_caustic: u32,
    /// Maximum global search radius as a fraction of the scene's bounding radius (default 0.1).
    pub global_radius: f32,
    /// Maximum caustic search radius as a fraction of the scene's bounding radius (0.02).
    pub caustic_radius: f32,
    /// Final-gather rays per shading point (default 4; 0 reads the global map directly).
    pub gather_rays: u32,
    /// Precompute irradiance at every n-th global photon (Christensen 1999) and let final-gather
    /// hits on Lambertian surfaces read the nearest record; 0 computes a full estimate per hit.
    pub irradiance_stride: u32,
    /// Memory budget of the photon maps and subsurface samples together, in MiB (default
    /// 8192; the command line defaults to half the machine's memory). Tracing stops with a
    /// settings error, naming the budget, as soon as the stored photons would exceed it
    /// (counting the copy made while the batches are joined).
    pub memory_limit_mib: u64,
    /// Photons emitted for the subsurface samples (default 1 000 000; only with a translucent
    /// material).
    pub subsurface_photons: u32,
    /// Jensen & Buhler's error bound: an octree node counts as one sample when the solid angle
    /// its samples' area subtends is below this (default 0.2; each node is taken to second
    /// order in its samples' spread, `crate::subsurface`).
    pub subsurface_accuracy: f32,
    /// Sum every subsurface sample instead of the octree (for tests and measurements).
    pub subsurface_brute_force: bool,
    /// Photons emitted for the volume photon map (default 200 000; only in scenes with
    /// scattering media).
    pub volume_photons: u32,
    /// Radius of a volume photon's disc in the beam estimate, as a fraction of the scene's
    /// bounding radius (default 0.015).
    pub volume_radius: f32,
}

impl Default for PhotonSettings {
    fn default() -> Self {
        PhotonSettings {
            global_photons: 200_000,
            caustic_photons: 100_000,
            k_global: 64,
            k_caustic: 64,
            global_radius: 0.1,
            caustic_radius: 0.02,
            gather_rays: 4,
            irradiance_stride: 4,
            memory_limit_mib: 8192,
            subsurface_photons: 1_000_000,
            subsurface_accuracy: 0.2,
            subsurface_brute_force: false,
            volume_photons: 200_000,
            volume_radius: 0.015,
        }
    }
}

impl PhotonSettings {
    /// The memory budget in bytes.
    pub fn memory_budget_bytes(&self) -> u64 {
        self.memory_limit_mib.saturating_mul(1 << 20)
    }
}

/// What photon tracing emitted, stored, skipped, and the time it took.
#[derive(Clone, Debug, Default)]
pub struct PhotonInfo {
    pub global_emitted: u64,
    pub global_stored: usize,
    pub caustic_emitted: u64,
    pub caustic_stored: usize,
    /// Why the caustic map was skipped, if it was.
    pub caustic_skipped: Option<String>,
    pub trace_seconds: f64,
    /// Some light's photons were guided (`super::guide`), and the pilots that guided them took
    /// `guide_seconds`.
    pub guided: bool,
    pub guide_seconds: f64,
    pub kdtree_seconds: f64,
    /// Precomputed irradiance records (Christensen 1999) and the time they took.
    pub irradiance_records: usize,
    pub irradiance_seconds: f64,
    pub subsurface_emitted: u64,
    pub subsurface_stored: usize,
    /// Why the subsurface photons were skipped, if they were.
    pub subsurface_skipped: Option<String>,
    /// Tracing the subsurface photons and building their octrees.
    pub subsurface_seconds: f64,
    pub volume_emitted: u64,
    pub volume_stored: usize,
    /// Tracing the volume photons and building their kd-tree.
    pub volume_seconds: f64,
}

impl PhotonInfo {
    /// Add another generation's counts and times (the reasons for skipping stay the first's).
    pub fn add(&mut self, other: &PhotonInfo) {
        self.global_emitted += other.global_emitted;
        self.global_stored += other.global_stored;
        self.caustic_emitted += other.caustic_emitted;
        self.caustic_stored += other.caustic_stored;
        self.caustic_skipped = self
            .caustic_skipped
            .take()
            .or(other.caustic_skipped.clone());
        self.trace_seconds += other.trace_seconds;
        self.guided |= other.guided;
        self.guide_seconds += other.guide_seconds;
        self.kdtree_seconds += other.kdtree_seconds;
        self.irradiance_records += other.irradiance_records;
        self.irradiance_seconds += other.irradiance_seconds;
        self.subsurface_emitted += other.subsurface_emitted;
        self.subsurface_stored += other.subsurface_stored;
        self.subsurface_skipped =
            (self.subsurface_skipped.take()).or(other.subsurface_skipped.clone());
        self.subsurface_seconds += other.subsurface_seconds;
        self.volume_emitted += other.volume_emitted;
        self.volume_stored += other.volume_stored;
        self.volume_seconds += other.volume_seconds;
    }
}
