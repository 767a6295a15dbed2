"""A weather file (EPW or TMY3) played on the ROS clock into the facade's weather inputs.

The node reads the file once at start (:func:`flectofold_model.environment.read_weather`)
and, every ``publish_period_s`` of ROS time, publishes the file's weather at that time:
direct normal irradiance, wind speed (the coordinator's storm input, times ``gust_factor``),
and diffuse irradiance, wind direction and air temperature. With ``use_sim_time`` it follows
``/clock`` (the sun node's simulated day, or a bag replay). Topics, parameters, the time
convention and the date mapping: ``msg_docs/weather.md``.
"""

import sys

import numpy as np
from rclpy.node import Node
from std_msgs.msg import Float64

from flectofold_model.environment import read_weather, uncovered, weather_at
from flectofold_ros.runtime.interfaces import publisher
from flectofold_ros.runtime.parameters import declare_all, double, string
from flectofold_ros.runtime.runner import configure_or_destroy, Program, run_nodes
from flectofold_ros.wire import contract

NS_PER_S = 10**9
#: A weather file further than this from the facade's site is warned about [deg of arc].
WEATHER_SITE_TOLERANCE_DEG = 1.0
USAGE = 'weather_node --ros-args -p weather_file:=PATH [-p name:=value ...]'

#: name -> Spec.
PARAMETERS = {
    'weather_file': string('', 'EPW or TMY3 weather file to play (required)',
                           constraints='a readable .epw or TMY3 .csv file'),
    'publish_period_s': double(10.0, 'Time between weather messages [s of ROS time]; keep it '
                               "below the coordinator's weather_timeout_s", 0.01, 3600.0),
    'gust_factor': double(1.0, "Factor from the file's hourly mean wind speed to the gust "
                          'speed published on wind_speed [-]', 1.0, 3.0),
}

#: Weather field -> the contract topic it is published on.
TOPICS = {
    'dni_w_m2': contract.DNI,
    'wind_speed_m_s': contract.WIND_SPEED,
    'dhi_w_m2': contract.DHI,
    'wind_direction_rad': contract.WIND_DIRECTION,
    'temperature_c': contract.AIR_TEMPERATURE,
}


class WeatherNode(Node):
    """Node ``weather``: publishes a weather file's readings at the ROS clock's time.

    A missing, malformed or out-of-range file raises
    :class:`~flectofold_model.environment.WeatherError` (a ``ValueError``) at start.
    """

    def __init__(self, **kwargs):
        super().__init__(contract.WEATHER_NODE, **kwargs)
        configure_or_destroy(self, self._configure)

    def _configure(self):
        declare_all(self, PARAMETERS)
        path = self.get_parameter('weather_file').value
        if not path:
            raise ValueError('parameter weather_file is required: an EPW or TMY3 file')
        self.weather = read_weather(path)
        self._gust_factor = self.get_parameter('gust_factor').value
        self._topic_publishers = {field: publisher(self, topic) for field, topic in TOPICS.items()}
        self.published = 0
        self.uncovered = 0
        """Messages published for a time the file does not cover (its nearest reading held)."""
        period_s = self.get_parameter('publish_period_s').value
        self.create_timer(period_s, self._on_timer)
        w = self.weather
        self.get_logger().info(
            f'{w.source}: {len(w.time_utc)} hourly rows, site {w.latitude_deg:.4f} deg N '
            f'{w.longitude_deg:.4f} deg E, UTC{w.utc_offset_h:+g} h; weather every '
            f'{period_s:g} s of ROS time')

    def _on_timer(self):
        now_ns = self.get_clock().now().nanoseconds
        if now_ns == 0:
            return  # use_sim_time before the first /clock
        self.publish_at(now_ns)

    def publish_at(self, epoch_ns):
        """Publish the file's weather at ``epoch_ns`` (POSIX nanoseconds, UTC)."""
        moment = np.datetime64(int(epoch_ns), 'ns')
        if reason := uncovered(self.weather, moment, moment):
            if not self.uncovered:  # once: the clock runs on, every message is as far out
                self.get_logger().warning(f'{reason}: holding its nearest reading')
            self.uncovered += 1
        values = readings_at(self.weather, epoch_ns, self._gust_factor)
        for field, value in values.items():
            self._topic_publishers[field].publish(Float64(data=value))
        self.published += 1


def readings_at(weather, epoch_ns, gust_factor=1.0):
    """Return ``{field: value}`` of ``weather`` at ``epoch_ns``, as the node publishes them."""
    values = weather_at(weather, np.datetime64(int(epoch_ns), 'ns'))
    readings = {field: float(values[field][0]) for field in TOPICS}
    readings['wind_speed_m_s'] *= gust_factor
    return readings


def main(args=None):
    """``ros2 run flectofold_ros weather_node --ros-args -p weather_file:=PATH``."""
    return run_nodes('weather_node', args, lambda: Program([WeatherNode()]), USAGE, PARAMETERS)


if __name__ == '__main__':
    sys.exit(main())
