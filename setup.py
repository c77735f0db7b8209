"""ament_python packaging of inclino_ros (src layout)."""

from glob import glob

from setuptools import find_packages, setup

package_name = 'inclino_ros'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages('src'),
    package_dir={'': 'src'},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml') + glob('config/*.xml')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='inclino_ros developers',
    maintainer_email='maintainers@users.noreply.h-seed-10448bf3.example',
    description='Corrected inclination, gravity toolface and bench calibration '
                'of a drilling-tool inclinometer.',
    license='Apache-2.0',
    extras_require={'test': ['pytest', 'hypothesis']},
    entry_points={
        'console_scripts': [
            'inclinometer_node = inclino_ros.node.inclinometer_node:main',
            'inclino = inclino_ros.cli.main:main',
        ],
    },
)
