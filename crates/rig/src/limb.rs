//! Limb names and the joint roles of a limb chain.

/// One of the four limbs, named by side and girdle (SPEC conventions).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Limb {
    /// Left fore limb.
    LF,
    /// Right fore limb.
    RF,
    /// Left hind limb.
    LH,
    /// Right hind limb.
    RH,
}

impl Limb {
    /// All limbs in a stable order (LF, RF, LH, RH); `Limb::index` follows it.
    pub const ALL: [Limb; 4] = [Limb::LF, Limb::RF, Limb::LH, Limb::RH];

    /// Short name: `"LF"`, `"RF"`, `"LH"`, `"RH"`.
    pub const fn name(self) -> &'static str {
        match self {
            Limb::LF => "LF",
            Limb::RF => "RF",
            Limb::LH => "LH",
            Limb::RH => "RH",
        }
    }

    /// Position in [`Limb::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Fore (shoulder girdle) limb?
    pub const fn is_fore(self) -> bool {
        matches!(self, Limb::LF | Limb::RF)
    }

    /// Left-side limb? (+X in model space: glTF's model faces +Z, so its left is +X.)
    pub const fn is_left(self) -> bool {
        matches!(self, Limb::LF | Limb::LH)
    }

    /// The other limb of the same girdle.
    pub const fn opposite(self) -> Limb {
        match self {
            Limb::LF => Limb::RF,
            Limb::RF => Limb::LF,
            Limb::LH => Limb::RH,
            Limb::RH => Limb::LH,
        }
    }

    /// The other limb of the same side (LF ↔ LH, RF ↔ RH).
    pub const fn same_side(self) -> Limb {
        match self {
            Limb::LF => Limb::LH,
            Limb::LH => Limb::LF,
            Limb::RF => Limb::RH,
            Limb::RH => Limb::RF,
        }
    }

    /// Parse `"LF"`/`"RF"`/`"LH"`/`"RH"`.
    pub fn from_name(name: &str) -> Option<Limb> {
        Limb::ALL.into_iter().find(|l| l.name() == name)
    }

    /// Anatomical names of the four chain elements, girdle first.
    pub const fn element_names(self) -> [&'static str; 4] {
        if self.is_fore() {
            ["Shoulder", "UpperArm", "ForeArm", "Hand"]
        } else {
            ["Pelvis", "Thigh", "LowerLeg", "Foot"]
        }
    }

    /// Name of the effector (tip of hand / foot).
    pub const fn tip_name(self) -> &'static str {
        if self.is_fore() { "HandTip" } else { "FootTip" }
    }

    /// Joint range (amplitude during contact, degrees) from SPEC, girdle first.
    pub const fn amplitudes_deg(self) -> [f32; 4] {
        if self.is_fore() {
            [41.5, 98.1, 92.3, 36.8]
        } else {
            [8.5, 75.7, 53.4, 17.8]
        }
    }
}

impl std::fmt::Display for Limb {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
