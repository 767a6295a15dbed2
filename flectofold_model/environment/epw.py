"""An NREL TMY3 file rewritten as an EnergyPlus weather file (EPW), field for field.

EnergyPlus reads EPW files only; pvlib ships its typical years as TMY3 (Greensboro, NC,
``723170TYA.CSV``). :func:`tmy3_to_epw` writes the same hours in the EPW's columns [1]_ from
the TMY3's [2]_: both stamp each hour at its end in local standard time, so the rows map one
to one. Unit changes: pressure mbar -> Pa, visibility m -> km, precipitable water cm -> mm.
What TMY3 does not carry is written as EPW's "missing" code: horizontal infrared from the sky
(9999: EnergyPlus computes it from the sky cover), the present-weather fields (9,
999999999), snow (0 cm, 88 days since). The header has no design conditions, typical periods
or ground temperatures (EnergyPlus warns; a room with adiabatic floors does not use them).

References
----------
.. [1] US DOE, "Auxiliary Programs", EnergyPlus documentation, ch. 2.9, "EnergyPlus Weather
   File (EPW) Data Dictionary".
.. [2] Wilcox, S. and Marion, W., "Users Manual for TMY3 Data Sets", NREL/TP-581-43156, 2008.
"""

from pathlib import Path
from typing import Any, Mapping, Union

from flectofold_model._validate import PathLike


def tmy3_to_epw(tmy3_path: PathLike, epw_path: PathLike) -> Path:
    """Write the TMY3 file ``tmy3_path`` as the EPW file ``epw_path``; return its path."""
    import pvlib
    data, meta = pvlib.iotools.read_tmy3(str(tmy3_path), map_variables=False)
    name = str(meta['Name']).strip('"').replace(',', ' ')
    header = [
        f'LOCATION,{name},{meta["State"]},USA,TMY3,{meta["USAF"]},{meta["latitude"]:.4f},'
        f'{meta["longitude"]:.4f},{meta["TZ"]:.1f},{meta["altitude"]:.1f}',
        'DESIGN CONDITIONS,0', 'TYPICAL/EXTREME PERIODS,0', 'GROUND TEMPERATURES,0',
        'HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0',
        f'COMMENTS 1,rewritten from the NREL TMY3 file {Path(tmy3_path).name} by flectofold',
        'COMMENTS 2,missing in TMY3: horizontal infrared (9999), present weather, snow',
        'DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31']
    columns = list(data.columns)
    rows = []
    for values in data.itertuples(index=False, name=None):
        record = dict(zip(columns, values))
        month, day, year = (int(part) for part in str(record['Date (MM/DD/YYYY)']).split('/'))
        hour = int(str(record['Time (HH:MM)']).split(':')[0])
        rows.append(_row(year, month, day, hour, record))
    Path(epw_path).write_text('\n'.join(header + rows) + '\n')
    return Path(epw_path)


def _row(year: int, month: int, day: int, hour: int, record: Mapping[str, Any]) -> str:
    def get(column: str) -> float:
        return float(record[column])
    fields: list[Union[int, float, str]]
    fields = [year, month, day, hour, 60, '?9?9?9?9E0?9?9?9?9?9?9?9?9?9?9?9?9?9?9?9*9*9?9?9?9',
              get('Dry-bulb (C)'), get('Dew-point (C)'), get('RHum (%)'),
              get('Pressure (mbar)') * 100.0, get('ETR (W/m^2)'), get('ETRN (W/m^2)'), 9999,
              get('GHI (W/m^2)'), get('DNI (W/m^2)'), get('DHI (W/m^2)'),
              get('GH illum (lx)'), get('DN illum (lx)'), get('DH illum (lx)'),
              get('Zenith lum (cd/m^2)'), get('Wdir (degrees)'), get('Wspd (m/s)'),
              get('TotCld (tenths)'), get('OpqCld (tenths)'), get('Hvis (m)') / 1000.0,
              get('CeilHgt (m)'), 9, 999999999, get('Pwat (cm)') * 10.0,
              get('AOD (unitless)'), 0, 88, get('Alb (unitless)'),
              get('Lprecip depth (mm)'), get('Lprecip quantity (hr)')]
    return ','.join(_text(value) for value in fields)


def _text(value: Union[int, float, str]) -> str:
    if isinstance(value, str):
        return value
    number = float(value)
    return str(int(number)) if number == int(number) else f'{number:.6g}'
