"""Wall models, slot ``BCType``: boundary particles of Akinci et al. (2012) or the boundary
elements of the WCSPH-BI spec (conservative or consistent). A wall model decides which wall
terms the other slots' choices use (each choice builds its own wall part for both kinds) and
owns the passes its walls need: the pseudo-mass, no-slip velocity and pressure of boundary
particles; the interpolated p and rho of consistent elements; the wall corrections (elastic
bounce, NBVC-PST) of boundary elements."""
from .registry import NONNEG, POS, UNIT, Choice, Param, add, one_of
from . import WallCorrection, WallPass
from .density import make_akinci_volume
from .renormalization import make_boundary_interpolation, make_boundary_store, make_noslip_velocity, make_wall_pressure
from .wall_corrections import make_init as make_wall_init
from .wall_corrections import make_store as make_wall_store
from .wall_corrections import make_wall_corrections

#: parameters of the boundary elements and their corrections, under the spec's names
ELEMENT_PARAMS = (
    Param("boundaryElementSize", 0.0, "boundary element size S: a length in 2D, an area in 3D; 0: dp "
          "(2D) or dp^2 (3D)", unit="m or m^2", check=NONNEG, spec=True),
    Param("massBoundary", 0.0, "boundary element mass (read for the spec's parameter table; elements carry "
          "no mass in these schemes)", unit="kg", check=NONNEG, spec=True),
    Param("enableElasticBounce", True, "elastic bounce of particles approaching an element", kind="bool", spec=True),
    Param("elasticBounce", "conservative", "'conservative' (EB-Conservative, e = 1) or 'epsilon' (EB-eps, "
          "e = elasticFactor)", kind="str", check=one_of("conservative", "epsilon")),
    Param("elasticFactor", 1.0, "e of the epsilon bounce", check=UNIT, spec=True),
    Param("r_boxFactor", 1.5, "r_box = r_boxFactor dp, the reach of an element's corrections", check=POS, spec=True),
    Param("minimalDistanceFactor", 0.5, "h_fac: the bounce keeps particles h_fac dp off the wall", check=NONNEG,
          spec=True),
    Param("enableNearBoundaryShifting", True, "NBVC-PST: particles closer than their radius (m/rho)^(1/d)/2 "
          "are moved back", kind="bool"),
)


def _element_values(q):
    m = q.m
    return {"r_box2": (m["r_boxFactor"] * q.dp) ** 2, "min_dist": m["minimalDistanceFactor"] * q.dp,
            "back": max(m["minimalDistanceFactor"], 0.55) * q.dp, "elastic": m["elasticFactor"]}


def _element_check(m):
    if m["elasticFactor"] != 1.0 and m["elasticBounce"] != "epsilon":
        return ("elasticFactor", f"{m['elasticFactor']:g} has no effect with elasticBounce = "
                f"{m['elasticBounce']!r}; set elasticBounce = \"epsilon\" for the EB-eps bounce")
    return None


def _particle_passes(ctx, q):
    """Psi from the wall lattice (``wall_volume = "akinci"``; else Psi is the fluid particle
    mass, no pass), then before each interaction the no-slip velocity (``wall_velocity =
    "adami"``) and the wall pressure (``wall_pressure = "adami"``), both made again before
    the wall loads."""
    m, out = q.m, []
    if m["wall_volume"] == "akinci":
        out.append(make_akinci_volume(ctx))
    if m["wall_velocity"] == "adami":
        out.append(WallPass(*make_noslip_velocity(ctx), writes=(("v_ext", "vector"),), velocity=True, loads=True))
    if m["wall_pressure"] == "adami":
        out.append(WallPass(*make_wall_pressure(ctx), writes=(("p", "scalar"), ("pr", "scalar")), reads=("a",),
                            loads=True))
    return out


def _element_passes(consistent):
    def passes(ctx, q):
        """Consistent scheme: each element's p_b and rho_b from its fluid neighbours before
        each interaction. After each step: the elastic bounce and NBVC-PST, when enabled."""
        m, out = q.m, []
        if consistent:
            init, store = make_boundary_store(ctx)
            out.append(WallPass(init, make_boundary_interpolation(ctx), store, writes=(("p", "scalar"), ("rho", "scalar")),
                                reads=("a",)))
        if m["enableElasticBounce"] or m["enableNearBoundaryShifting"]:
            term = make_wall_corrections(ctx, m["enableElasticBounce"], m["elasticBounce"] == "epsilon",
                                         m["enableNearBoundaryShifting"])
            out.append(WallCorrection(make_wall_init(ctx), term, make_wall_store(ctx)))
        return out

    return passes


#: the wall sets' fields and what the fluid's wall terms read of them
PARTICLE_FIELDS = (("psi", "scalar"), ("vol", "scalar"), ("rho", "scalar"))
ELEMENT_FIELDS = (("p", "scalar"), ("rho", "scalar"))
ELEMENT_READS = {None: ("a", "n", "elementSize", "p", "rho")}

add("walls", Choice(
    "AkinciBoundaryParticles", "Akinci et al. (2012), wall pressure of Adami et al. (2012) or mirrored (Band et al. 2018)",
    "wall particles, pseudo-mass Psi_k; the fluid's terms continued over them",
    params=(Param("wall_layers", 0, "layers of wall particles; 0: the kernel support (lattice volume) or 1 "
                  "(akinci volume)", kind="int", check=NONNEG),
            Param("wall_volume", "lattice", "'lattice' (Psi = the fluid particle mass) or 'akinci' (Psi = rho0 "
                  "/ sum_l W_kl, eq. 5)", kind="str", check=one_of("lattice", "akinci")),
            Param("wall_velocity", "prescribed", "the velocity the wall terms read: 'prescribed' (the wall's "
                  "own) or 'adami' (no-slip: 2 v_w minus the fluid velocity interpolated at the wall "
                  "particle, Adami, Hu & Adams 2012)", kind="str", check=one_of("prescribed", "adami")),
            Param("wall_pressure", "adami", "the pressure the wall terms read: 'mirror' (the fluid "
                  "particle's own, Band et al. 2018) or 'adami' (the fluid's pressure interpolated at the "
                  "wall particle with the hydrostatic correction, Adami, Hu & Adams 2012 eq. 27)",
                  kind="str", check=one_of("mirror", "adami"))),
    walls=("particles",), boundary="particles", passes=_particle_passes, wall_fields=PARTICLE_FIELDS,
    wall_reads={None: ("psi",), "wall_volume": ("vol", "rho")}))
add("walls", Choice(
    "BIConservative_numeric", "WCSPH-BI spec, conservative boundary integrals",
    "boundary elements (x, n, S); no renormalization", params=ELEMENT_PARAMS,
    p_fields=("r_box2", "min_dist", "back", "elastic"), values=_element_values, check=_element_check,
    walls=("elements",), boundary="elements", passes=_element_passes(False), wall_fields=ELEMENT_FIELDS,
    wall_reads=ELEMENT_READS))
add("walls", Choice(
    "BIConsistent_numeric", "WCSPH-BI spec, consistent boundary integrals",
    "boundary elements; Shepard factor gamma_i, wall pressure interpolated from the fluid",
    params=ELEMENT_PARAMS, p_fields=("r_box2", "min_dist", "back", "elastic"), values=_element_values,
    check=_element_check, walls=("elements",), boundary="elements", consistent=True,
    passes=_element_passes(True), wall_fields=ELEMENT_FIELDS, wall_reads=ELEMENT_READS))
