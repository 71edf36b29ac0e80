"""Every file format: tank records (and lab files of tank data), ship files, hull files, and the labelled results
(netCDF)."""

from .._atomic import (
    atomic_write_bytes as atomic_write_bytes,
    clear_interrupt as clear_interrupt,
    note_interrupt as note_interrupt,
    raise_if_interrupted as raise_if_interrupted,
)
from ._dataset import (
    dataset_attrs as dataset_attrs,
    output_dataset as output_dataset,
    provenance as provenance,
    read_dataset as read_dataset,
    to_jsonable as to_jsonable,
    write_dataset as write_dataset,
)
from ._gdf import (
    panels_to_triangles as panels_to_triangles,
    read_gdf as read_gdf,
    read_gdf_hull as read_gdf_hull,
    write_gdf as write_gdf,
)
from ._hull_file import (
    hull_to_toml as hull_to_toml,
    load_hull as load_hull,
    loading_from_dict as loading_from_dict,
    read_hull_file as read_hull_file,
)
from ._lab_files import (
    LabTable as LabTable,
    describe_lab_file as describe_lab_file,
    import_record as import_record,
    read_lab_table as read_lab_table,
)
from ._mesh import (
    MeshError as MeshError,
    ModelScaleError as ModelScaleError,
    hull_from_triangles as hull_from_triangles,
    read_hull as read_hull,
    read_mesh as read_mesh,
    read_offsets_csv as read_offsets_csv,
    read_stl as read_stl,
    read_stl_hull as read_stl_hull,
    triangulate_offsets as triangulate_offsets,
    write_offsets_csv as write_offsets_csv,
    write_stl as write_stl,
)
from ._records import (
    RECORD_COLUMNS as RECORD_COLUMNS,
    Record as Record,
    RecordError as RecordError,
    group_by_sea_state as group_by_sea_state,
    load_record as load_record,
    load_records as load_records,
    make_record as make_record,
    record_to_text as record_to_text,
    save_record as save_record,
)
from ._ship_file import (
    damping_source as damping_source,
    load_ship as load_ship,
    ship_from_dict as ship_from_dict,
    ship_to_dict as ship_to_dict,
    ship_to_toml as ship_to_toml,
)
