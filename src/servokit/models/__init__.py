"""Plants and controllers: modal plants with delay, exact discretisation, variation
sets, the built-in catalogue, the book's controllers and TOML plant/controller files."""

from servokit.models.benchmark_controller import (
    BENCHMARK_NOTCHES,
    benchmark_controller,
    benchmark_controller_data,
    ieej_benchmark_loop,
    ieej_example_controller,
)
from servokit.models.catalogue import (
    CATALOGUE,
    HDD_BENCHMARK_TS,
    HDD_SAMPLED_DATA_TS,
    galvano_scanner,
    hdd_benchmark,
    hdd_sampled_data,
    ieej_benchmark_plant,
    personal_mobility_robot,
    pzt_active_suspension,
    svm_head_plant,
    vcm_dual_stage,
)
from servokit.models.controllers import (
    CONTROLLERS,
    VCM_PES_TS,
    cnc_eq_4_73,
    controller_eq_4_69,
    controller_fig_4_57,
    cpc_eq_4_72,
    vcm_controller_table_5_2,
)
from servokit.models.disturbances import (
    BenchmarkDisturbances,
    DisturbanceRecord,
    band_powers,
    disturbance_magnitude,
)
from servokit.models.files import (
    PlantFileError,
    load_controller,
    load_plant,
    save_controller,
    save_plant,
)
from servokit.models.fit import BandError, ModalFit, delay_from_phase, fit_modal
from servokit.models.frf import FRF_MAX_BYTES, FrfFileError, read_frf, save_frf
from servokit.models.hdd_box import hdd_benchmark_variants, hdd_benchmark_variation_set
from servokit.models.lookup import get_discrete_controller, get_discrete_rational, get_plant
from servokit.models.modal import ModalPlant, Mode, modal_matrices, without_delay
from servokit.models.plots import fit_plot
from servokit.models.rational import RationalTF, StateSpaceData, rational_zpk
from servokit.models.tf import require_proper, zpk
from servokit.models.variation_file import (
    HDD_BENCHMARK_VARIATIONS,
    VariationFileError,
    read_variations,
)
from servokit.models.variations import Perturbation, VariationSet

__all__ = [
    "BENCHMARK_NOTCHES",
    "BenchmarkDisturbances",
    "DisturbanceRecord",
    "band_powers",
    "disturbance_magnitude",
    "benchmark_controller",
    "benchmark_controller_data",
    "ieej_benchmark_loop",
    "ieej_benchmark_plant",
    "ieej_example_controller",
    "CATALOGUE",
    "CONTROLLERS",
    "get_discrete_controller",
    "get_discrete_rational",
    "RationalTF",
    "StateSpaceData",
    "rational_zpk",
    "require_proper",
    "HDD_BENCHMARK_TS",
    "HDD_SAMPLED_DATA_TS",
    "VCM_PES_TS",
    "BandError",
    "ModalFit",
    "delay_from_phase",
    "fit_modal",
    "fit_plot",
    "FRF_MAX_BYTES",
    "FrfFileError",
    "read_frf",
    "save_frf",
    "ModalPlant",
    "Mode",
    "Perturbation",
    "PlantFileError",
    "VariationSet",
    "HDD_BENCHMARK_VARIATIONS",
    "VariationFileError",
    "read_variations",
    "cnc_eq_4_73",
    "controller_eq_4_69",
    "controller_fig_4_57",
    "cpc_eq_4_72",
    "galvano_scanner",
    "get_plant",
    "hdd_benchmark",
    "hdd_benchmark_variants",
    "hdd_benchmark_variation_set",
    "hdd_sampled_data",
    "load_controller",
    "load_plant",
    "modal_matrices",
    "personal_mobility_robot",
    "pzt_active_suspension",
    "save_controller",
    "save_plant",
    "svm_head_plant",
    "vcm_controller_table_5_2",
    "vcm_dual_stage",
    "without_delay",
    "zpk",
]
